"""The participant's page, served on the loopback address with the standard library's HTTP server.

``GET /`` is the page (``page/``, package data); ``GET /api/state`` says what
it shows; ``POST /api/proceed``, ``/api/play`` and ``/api/answer`` act on the
session and answer with the new state. POSTs carry the run's token (written
into the page) and JSON, so another site open in the same browser cannot
send answers.
"""

from __future__ import annotations

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


def _asset(name: str) -> bytes:
    return resources.files("hapticfx.study").joinpath("page", name).read_bytes()


class StudyServer:
    """Serves one session's page on ``host:port`` (port 0: any free one) from a background thread."""

    def __init__(self, session: Session, *, host: str = "127.0.0.1", port: int = 0):
        self.session = session
        self.token = secrets.token_urlsafe(16)
        self.pages = {path: (_asset(name).replace(b"{{TOKEN}}", self.token.encode()), kind)
                      for path, (name, kind) in ASSETS.items()}
        self.httpd = ThreadingHTTPServer((host, port), self._handler())
        self.httpd.daemon_threads = True
        self.errors: list[str] = []
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        host, port = self.httpd.server_address[:2]
        return f"http://{host}:{port}/"

    def _handler(self):
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):  # the terminal belongs to the experimenter
                pass

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
                if self.path == "/api/state":
                    return self._json(200, server.session.state())
                page = server.pages.get(self.path)
                if page is None:
                    return self._json(404, {"error": f"no page {self.path}"})
                self._send(200, *page)

            def do_POST(self):
                if self.headers.get("X-Study-Token") != server.token:
                    return self._json(403, {"error": "this page belongs to another run; reload it"})
                length = int(self.headers.get("Content-Length") or 0)
                if not 0 < length <= MAX_BODY or not self.headers.get("Content-Type", "").startswith("application/json"):
                    return self._json(400, {"error": "expected a JSON body"})
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
                    server.errors.append(str(exc))
                    return self._json(500, {"error": f"the impact could not be played: {exc}"})
                self._json(200, state)

        return Handler

    def start(self) -> "StudyServer":
        self._thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.1},
                                        name="hapticfx-study-page", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
        if self._thread is not None:
            self._thread.join(5)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False
