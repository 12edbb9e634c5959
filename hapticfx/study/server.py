"""The participant's page, served on the loopback address with the standard library's HTTP server.

``GET /`` is the page (``page/``, package data); ``GET /api/state`` says what
it shows; ``POST /api/proceed``, ``/api/play`` and ``/api/answer`` act on the
session and answer with the new state.

What another site open in the same browser can do is nothing:

- every request whose ``Host`` is not a loopback name (``localhost``,
  ``127.x.x.x``, ``[::1]``), or whose ``Origin``, when sent, is not a loopback
  origin, is refused with 403 before anything else, so a page that rebinds its
  own DNS name to 127.0.0.1 can neither read the token out of the page nor act;
- every ``/api/`` route needs the run's token (written into the page) in
  ``X-Study-Token``; the actions take JSON only;
- a malformed request (a ``Content-Length`` that is not a number, a body that
  is not the JSON expected) is answered 400 and changes nothing.
"""

from __future__ import annotations

import ipaddress
import json
import secrets
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources

from ..errors import HapticfxError
from .session import AnswerRefused, Session

ASSETS = {"/": ("index.html", "text/html; charset=utf-8"), "/app.js": ("app.js", "text/javascript; charset=utf-8"),
          "/style.css": ("style.css", "text/css; charset=utf-8")}
MAX_BODY = 64 * 1024
READ_TIMEOUT_S = 10.0  # a client that stops sending half-way holds one thread this long at most


def loopback_name(host: str | None) -> bool:
    """Whether ``host`` (a Host header's value, with or without its port) names this machine's loopback."""
    if not host:
        return False
    name = host.strip().lower()
    if name.startswith("["):  # [::1] or [::1]:port
        name = name[1:name.find("]")] if "]" in name else ""
    elif name.count(":") == 1:
        name, port = name.split(":")
        if not port.isdigit():
            return False
    if name in ("localhost", "localhost."):
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def loopback_origin(origin: str) -> bool:
    """Whether an ``Origin`` header names an http page on this machine's loopback."""
    scheme, sep, rest = origin.strip().partition("://")
    return bool(sep) and scheme.lower() == "http" and "/" not in rest and loopback_name(rest)


def _asset(name: str) -> bytes:
    return resources.files("hapticfx.study").joinpath("page", name).read_bytes()


class StudyServer:
    """Serves one session's page on ``host:port`` (port 0: any free one) from a background thread.

    The port is bound on construction, so that a port in use is refused before a session
    opens its results; ``session`` may then be given later, before :meth:`start`.
    """

    def __init__(self, session: Session | None, *, host: str = "127.0.0.1", port: int = 0):
        self.session = session
        self.token = secrets.token_urlsafe(16)
        self.pages = {path: (_asset(name).replace(b"{{TOKEN}}", self.token.encode()), kind)
                      for path, (name, kind) in ASSETS.items()}
        if not loopback_name(host):
            raise HapticfxError(f"the study page is served on the loopback address only, not {host!r}")
        self.errors: list[str] = []
        try:
            self.httpd = _Server((host, port), self._handler(), self.errors)
        except (OSError, OverflowError) as exc:  # OverflowError: a port outside 0-65535
            raise HapticfxError(f"cannot serve the participant's page on {host}:{port}: "
                                f"{getattr(exc, 'strerror', None) or exc}; choose another with --port "
                                "(0: any free port)") from None
        self.httpd.daemon_threads = True
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        host, port = self.httpd.server_address[:2]
        return f"http://{host}:{port}/"

    def _handler(self):
        server = self

        class Handler(BaseHTTPRequestHandler):
            timeout = READ_TIMEOUT_S

            def log_message(self, *args):  # the terminal belongs to the experimenter
                pass

            def _refused(self, *, api: bool) -> bool:
                """Answer 403 (and True) for a foreign Host or Origin, or an API call without the token."""
                origin = self.headers.get("Origin")
                if not loopback_name(self.headers.get("Host")) or (origin is not None and not loopback_origin(origin)):
                    self._json(403, {"error": "this page answers on the loopback address only (localhost, 127.0.0.1)"})
                    return True
                if api and not secrets.compare_digest(self.headers.get("X-Study-Token", "").encode("utf-8", "surrogateescape"),
                                                      server.token.encode()):
                    self._json(403, {"error": "this page belongs to another run; reload it"})
                    return True
                return False

            def _send(self, status: int, body: bytes, kind: str) -> None:
                self.send_response(status)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def _json(self, status: int, data: dict) -> None:
                self._send(status, json.dumps(data).encode(), "application/json")

            def do_GET(self):
                if self._refused(api=self.path.startswith("/api/")):
                    return None
                if self.path == "/api/state":
                    return self._json(200, server.session.state())
                page = server.pages.get(self.path)
                if page is None:
                    return self._json(404, {"error": f"no page {self.path}"})
                self._send(200, *page)

            def do_POST(self):
                if self._refused(api=True):
                    return None
                length = self.headers.get("Content-Length", "").strip()
                if not (length.isdigit() and 0 < int(length) <= MAX_BODY) \
                        or not self.headers.get("Content-Type", "").startswith("application/json"):
                    self.close_connection = True  # the body's end is unknown: read no further
                    return self._json(400, {"error": f"expected a JSON body of 1 to {MAX_BODY} bytes with its "
                                                    "Content-Length"})
                length = int(length)
                try:
                    body = json.loads(self.rfile.read(length))
                    index = body["trial"]
                    if not isinstance(index, int) or isinstance(index, bool):
                        raise TypeError
                except (ValueError, KeyError, TypeError):
                    return self._json(400, {"error": "expected JSON with an integer 'trial'"})
                session = server.session
                try:
                    if self.path == "/api/proceed":
                        state = session.proceed(index, body.get("screen"))
                    elif self.path == "/api/play":
                        session.play(index, body.get("slot"))
                        state = session.state()
                    elif self.path == "/api/answer":
                        state = session.answer(index, body.get("response"))
                    else:
                        return self._json(404, {"error": f"no action {self.path}"})
                except AnswerRefused as exc:
                    return self._json(HTTPStatus.CONFLICT, {"error": str(exc)})
                except HapticfxError as exc:  # the device failed: the experimenter must see it too
                    server.errors.append(f"device error: {exc}")
                    return self._json(500, {"error": f"the impact could not be played: {exc}"})
                self._json(200, state)

        return Handler

    def start(self) -> "StudyServer":
        self._thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.1},
                                        name="hapticfx-study-page", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and free the port; stopping a server never started, or stopped, only frees the port."""
        if self._thread is not None:  # shutdown() waits for serve_forever(), forever if it never ran
            self.httpd.shutdown()
            self._thread.join(5)
            self._thread = None
        self.httpd.server_close()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False


class _Server(ThreadingHTTPServer):
    """The page's HTTP server: an exception in a handler (a client gone half-way, or a bug) is one line in
    ``errors`` for the experimenter, never a traceback on the terminal."""

    def __init__(self, address, handler, errors: list[str]):
        self.errors = errors
        super().__init__(address, handler)

    def handle_error(self, request, client_address) -> None:
        import sys

        exc = sys.exc_info()[1]
        if isinstance(exc, (ConnectionError, TimeoutError)):
            return  # the client went away: nothing to tell
        self.errors.append(f"the study page failed on a request: {type(exc).__name__}: {exc}")
