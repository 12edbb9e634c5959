"""Open Sound Control over UDP: the network bridge of ``hapticfx serve``.

A datagram is one OSC message or a bundle of them. The protocol (version
:data:`PROTOCOL_VERSION`) is in ``docs/protocol.md``; the one message that renders is::

    /hapticfx/impact <object:s> <velocity:f|d|i> [<channel:i> [<at:f|d> [<point:3x f|d> [<normal:3x f|d>]]]]

A bundle's timetag is the engine's time of the impacts it holds (unless a
message carries its own ``at``). With a shared secret (``secret=``,
``hapticfx serve --secret-file``) a message from another machine must be
addressed ``/<secret>/hapticfx/impact``; the plain address keeps working from
this machine. The bridge binds to a loopback address unless ``allow_remote``
is set.

Every message that arrives is either handed to the engine or dropped, and
each drop is counted under one reason (:data:`DROP_REASONS`), so that
``received == accepted + sum(dropped)`` always holds. Nothing a sender does
stops the server: decoding is strict, bounded by the datagram size, and runs
on bytes that are never trusted.

The decoder is our own (about forty lines) rather than python-osc's, because
python-osc logs a warning per unknown type tag, skips such arguments, and
raises ``UnicodeDecodeError`` as well as ``ParseError``: under a flood that is
log spam and leniency we do not want. Clients (tests, benchmarks, examples)
use python-osc to build messages, so both implementations meet on the wire.
"""

from __future__ import annotations

import hmac
import ipaddress
import logging
import math
import re
import socket
import struct
import threading
import time
from dataclasses import dataclass, field
from typing import Callable

from .errors import HapticfxError
from .interfaces import MAX_POINT_M
from .signal import MAX_AT_S, MAX_VELOCITY_MPS

log = logging.getLogger(__name__)

IMPACT_ADDRESS = "/hapticfx/impact"
PROTOCOL_VERSION = 2  # 1: object, velocity, channel, at; 2: + contact point and normal, bundles with timetags
MAX_BUNDLE_DEPTH = 4   # a bundle nested deeper than this is one dropped element (reason `bundle`)

DROP_REASONS = (
    "oversize",        # longer than max_datagram bytes
    "rate_limited",    # over the token bucket (checked before any decoding)
    "not_osc",         # not a well-formed OSC 1.0 message
    "bundle",          # a malformed or empty OSC bundle, or one nested too deep (that element alone)
    "wrong_address",   # a well-formed message to an address we do not serve
    "unauthorized",    # /<secret>/hapticfx/impact with a wrong secret, or the plain address from another machine
    "wrong_types",     # right address, type tags not one of the documented forms
    "bad_value",       # velocity negative, non-finite or above 100 m/s, channel < -1, non-finite or huge time, non-finite
                       # point or normal, a point over MAX_POINT_M from the head's centre, a zero normal
    "unknown_object",  # object id not in the scene
    "queue_full",      # the engine's queue was full
    "engine_refused",  # the engine rejected it for another reason (closed, invalid)
)


SECRET_PATTERN = re.compile(r"[A-Za-z0-9_-]{16,128}")


def check_secret(secret: str, *, source: str = "the OSC secret") -> str:
    """``secret`` if it can stand in an OSC address (16-128 letters, digits, ``_`` or ``-``)."""
    if not SECRET_PATTERN.fullmatch(secret):  # the message never shows the secret
        got = f"{len(secret)} characters" if not 16 <= len(secret) <= 128 else "other characters"
        raise HapticfxError(f"{source}: expected 16 to 128 letters, digits, '_' or '-' (it becomes part of the OSC "
                            f"address), got {got}")
    return secret


class OscDecodeError(HapticfxError):
    """A datagram that is not a well-formed OSC message; ``reason`` is a drop reason."""

    def __init__(self, reason: str, detail: str):
        super().__init__(detail)
        self.reason = reason


def _read_string(data: bytes, pos: int) -> tuple[str, int]:
    end = data.find(b"\x00", pos)
    if end < 0:
        raise OscDecodeError("not_osc", "unterminated string")
    try:
        text = data[pos:end].decode("utf-8")
    except UnicodeDecodeError:
        raise OscDecodeError("not_osc", "string is not UTF-8") from None
    nxt = (end + 4) & ~3  # the string, its NUL, then padding to a multiple of 4
    if nxt > len(data) or any(data[end:nxt]):
        raise OscDecodeError("not_osc", "bad string padding")
    return text, nxt


_FIXED = {"i": (">i", 4), "f": (">f", 4), "h": (">q", 8), "d": (">d", 8)}


def decode_message(data: bytes) -> tuple[str, str, list]:
    """Decode one OSC 1.0 message: ``(address, type_tags, arguments)``.

    Supports the argument types ``i f h d s`` (what the protocol uses);
    any other type tag is ``wrong_types`` only if the address is ours, so the
    caller sees ``(address, tags, None)`` for a message it cannot read.
    Raises :class:`OscDecodeError` for anything that is not OSC.
    """
    if len(data) < 8 or len(data) % 4:
        raise OscDecodeError("not_osc", f"length {len(data)} is not a positive multiple of 4")
    if data.startswith(BUNDLE_HEAD):
        raise OscDecodeError("bundle", "a bundle, not a message (see split_bundle)")
    if data[0:1] != b"/":
        raise OscDecodeError("not_osc", "address does not start with '/'")
    address, pos = _read_string(data, 0)
    if pos >= len(data):  # OSC 1.0 allows a missing type tag string; we require it
        raise OscDecodeError("not_osc", "no type tag string")
    tags, pos = _read_string(data, pos)
    if not tags.startswith(","):
        raise OscDecodeError("not_osc", "type tag string does not start with ','")
    tags = tags[1:]
    if any(t not in "ifhds" for t in tags):
        return address, tags, None
    args: list = []
    for tag in tags:
        if tag == "s":
            value, pos = _read_string(data, pos)
        else:
            fmt, size = _FIXED[tag]
            if pos + size > len(data):
                raise OscDecodeError("not_osc", "arguments run past the end of the datagram")
            (value,) = struct.unpack_from(fmt, data, pos)
            pos += size
        args.append(value)
    if pos != len(data):
        raise OscDecodeError("not_osc", f"{len(data) - pos} trailing byte(s)")
    return address, tags, args


BUNDLE_HEAD = b"#bundle\x00"
IMMEDIATELY = 1  # the timetag that means "now": no time
NTP_TO_UNIX_S = 2_208_988_800  # seconds from 1900 (NTP's epoch) to 1970 (Unix's)


def timetag_seconds(timetag: int) -> float | None:
    """An OSC timetag (NTP: 32-bit seconds since 1900, 32-bit fraction) as seconds since 1970; None for
    'immediately'. python-osc's ``OscBundleBuilder(t)`` and liblo's ``lo_timetag`` from a time ``t`` give ``t``."""
    if timetag == IMMEDIATELY:
        return None
    return ((timetag >> 32) - NTP_TO_UNIX_S) + (timetag & 0xFFFFFFFF) / 2**32


def split_bundle(data: bytes, *, depth: int = 0) -> list[tuple[bytes, float | None]]:
    """The messages of an OSC bundle (nested bundles flattened), each with its innermost timetag in seconds.

    A bundle nested deeper than :data:`MAX_BUNDLE_DEPTH` is not opened: it stays one element, which
    :func:`decode_message` refuses (``bundle``), so the messages beside it still count on their own.
    Raises :class:`OscDecodeError` (``bundle``) for an empty or malformed bundle; the messages
    themselves are not decoded here.
    """
    if len(data) < 24 or len(data) % 4 or not data.startswith(BUNDLE_HEAD):
        raise OscDecodeError("bundle", "a bundle needs '#bundle', a timetag and at least one element")
    (timetag,) = struct.unpack_from(">Q", data, 8)
    at = timetag_seconds(timetag)
    out: list[tuple[bytes, float | None]] = []
    pos = 16
    while pos < len(data):
        if pos + 4 > len(data):
            raise OscDecodeError("bundle", "element size runs past the end of the bundle")
        (size,) = struct.unpack_from(">i", data, pos)
        pos += 4
        if size <= 0 or size % 4 or pos + size > len(data):
            raise OscDecodeError("bundle", f"element of {size} byte(s) does not fit the bundle")
        element = data[pos:pos + size]
        pos += size
        if element.startswith(BUNDLE_HEAD) and depth < MAX_BUNDLE_DEPTH:
            out.extend(split_bundle(element, depth=depth + 1))
        else:
            out.append((element, at))
    return out


def _osc_string(text: str) -> bytes:
    raw = text.encode("utf-8") + b"\x00"
    return raw + b"\x00" * (-len(raw) % 4)


def encode_impact(object: str, velocity: float, channel: int | None = None, at: float | None = None,
                  point=None, normal=None) -> bytes:
    """The datagram ``/hapticfx/impact`` with floats (``,sf``) and, as given, channel (``i``), time (``d``),
    point and normal (``fff`` each); a later field needs the earlier ones (channel None: -1, the scene's)."""
    if (point is not None and at is None) or (normal is not None and point is None):
        raise ValueError("a point needs a time, and a normal needs a point")
    tags, body = "sf", struct.pack(">f", velocity)
    if channel is not None or at is not None or point is not None:
        tags, body = tags + "i", body + struct.pack(">i", -1 if channel is None else channel)
    if at is not None:
        tags, body = tags + "d", body + struct.pack(">d", at)
    for vector in (point, normal):
        if vector is not None:
            tags, body = tags + "fff", body + struct.pack(">3f", *vector)
    return _osc_string(IMPACT_ADDRESS) + _osc_string("," + tags) + _osc_string(object) + body


@dataclass(frozen=True)
class ImpactMessage:
    """A decoded ``/hapticfx/impact``: object, velocity, and the optional channel, time, contact point and normal."""

    object: str
    velocity: float
    channel: int | None = None
    at: float | None = None
    point: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None


# s, a velocity, then optional groups, each needing the one before: channel, time, point (3), normal (3).
# Version 1's forms (',sf' ... ',siid') are the first three levels.
_IMPACT_FORM = re.compile(r"s[fdi](?:i(?:[fd](?:[fd]{3}(?:[fd]{3})?)?)?)?")


def _vector(args: list, name: str) -> tuple[float, float, float]:
    v = tuple(float(a) for a in args)
    if not all(math.isfinite(c) for c in v):
        raise OscDecodeError("bad_value", f"{name} {v} is not three finite numbers")
    return v


def parse_impact(tags: str, args: list | None, *, at: float | None = None) -> ImpactMessage:
    """Check an ``/hapticfx/impact`` message's arguments; raises :class:`OscDecodeError`.

    ``at``: the time of the bundle that held the message, used when the message carries none.
    """
    if args is None or not _IMPACT_FORM.fullmatch(tags):
        raise OscDecodeError("wrong_types", f"type tags ',{tags}'; expected ',sf', ',sfi', ',sfid', ',sfidddd' "
                                            "or ',sfidddddd' (docs/protocol.md)")
    obj, velocity = args[0], float(args[1])
    channel = args[2] if len(args) > 2 else -1
    if len(args) > 3:
        at = float(args[3])
    if not math.isfinite(velocity) or not 0 <= velocity <= MAX_VELOCITY_MPS:
        raise OscDecodeError("bad_value", f"velocity {velocity:g} is not a finite number in [0, {MAX_VELOCITY_MPS:g}] m/s")
    if channel < -1:
        raise OscDecodeError("bad_value", f"channel {channel} (use -1 for the scene's channel)")
    if at is not None and not (math.isfinite(at) and abs(at) <= MAX_AT_S):
        raise OscDecodeError("bad_value", f"time {at:g} is not a finite number of seconds within {MAX_AT_S:g}")
    point = _vector(args[4:7], "point") if len(args) > 4 else None
    if point is not None and max(map(abs, point)) > MAX_POINT_M:  # not on a head: the spatialiser's norms overflowed
        raise OscDecodeError("bad_value", f"point {point} is not within {MAX_POINT_M:g} m of the head's centre")
    normal = _vector(args[7:10], "normal") if len(args) > 7 else None
    if normal is not None and math.hypot(*normal) < 1e-9:
        raise OscDecodeError("bad_value", "normal is zero")
    return ImpactMessage(obj, velocity, None if channel == -1 else channel, at, point, normal)


class TokenBucket:
    """At most ``rate_hz`` per second on average, ``burst`` at once. ``rate_hz == 0``: unlimited."""

    def __init__(self, rate_hz: float, burst: int, clock: Callable[[], float] = time.monotonic):
        self.rate_hz = float(rate_hz)
        self.burst = float(max(1, burst))
        self.tokens = self.burst
        self.clock = clock
        self.last = clock()

    def take(self, n: int = 1) -> int:
        """Take up to ``n`` tokens; how many were there (``n`` when unlimited)."""
        if self.rate_hz <= 0:
            return n
        now = self.clock()
        self.tokens = min(self.burst, self.tokens + (now - self.last) * self.rate_hz)
        self.last = now
        taken = min(n, int(self.tokens))
        self.tokens -= taken
        return taken


@dataclass
class BridgeCounters:
    """What the bridge saw: ``received == accepted + sum(dropped.values())``."""

    received: int = 0
    accepted: int = 0
    dropped: dict[str, int] = field(default_factory=lambda: dict.fromkeys(DROP_REASONS, 0))
    kernel_dropped: int | None = None  # datagrams the OS dropped before we read them (Linux)

    def as_dict(self) -> dict:
        return {
            "received": self.received, "accepted": self.accepted,
            "dropped": dict(self.dropped), "dropped_total": sum(self.dropped.values()),
            "kernel_dropped": self.kernel_dropped,
        }


def _loopback(ip: str) -> bool:
    return ip.startswith("127.")  # the socket is IPv4


def _kernel_drops(sock: socket.socket) -> int | None:
    """The drop count Linux keeps for this UDP socket (``/proc/net/udp``), or None."""
    host, port = sock.getsockname()[:2]
    want = f"{socket.htonl(struct.unpack('!I', socket.inet_aton(host))[0]):08X}:{port:04X}"
    try:
        with open("/proc/net/udp") as fh:
            next(fh)
            for line in fh:
                cols = line.split()
                if cols[1] == want:
                    return int(cols[-1])
    except (OSError, ValueError, StopIteration):
        return None
    return None


Submit = Callable[[ImpactMessage, float], bool]


def _setting(value, name: str, lo: float, hi: float, *, whole: bool = False) -> None:
    """Refuse a bridge setting that is not a (whole) number in ``[lo, hi]``."""
    number = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
    if not number or not lo <= value <= hi or (whole and value != int(value)):
        raise HapticfxError(f"{name} must be {'a whole number' if whole else 'a number'} in [{lo:g}, {hi:g}], got "
                            f"{value!r}"[:200])


class OscBridge:
    """Receives OSC datagrams (messages or bundles) on a UDP socket and submits impacts.

    ``submit(message, received_at)`` (usually :meth:`hapticfx.Engine.submit`)
    returns True when queued, False when the queue was full; it may raise a
    :class:`~hapticfx.errors.HapticfxError` for a message it refuses.
    ``known_objects`` are the scene's object ids. One receiving thread; a
    datagram is handled completely before the next is read, so the counters
    need no lock (readers get a consistent-enough snapshot via :meth:`stats`).
    """

    def __init__(self, submit: Submit, known_objects, *, host: str = "127.0.0.1", port: int = 9000,
                 max_datagram: int = 1024, rate_hz: float = 2000.0, burst: int = 500,
                 recv_buffer: int = 4 << 20, allow_remote: bool = False, secret: str | None = None):
        # as a scene's events.osc section allows them: inf or NaN here killed the receiver or lifted the limit
        _setting(max_datagram, "max_datagram", 16, 65507, whole=True)
        _setting(rate_hz, "rate_hz", 0.0, 1e9)
        _setting(burst, "burst", 1, 1_000_000, whole=True)
        _setting(port, "port", 0, 65535, whole=True)
        if not isinstance(host, str):
            raise HapticfxError(f"host must be an address such as '127.0.0.1', got {type(host).__name__}")
        self.submit = submit
        self._secret_address = None if secret is None else f"/{check_secret(secret)}{IMPACT_ADDRESS}".encode()
        self.known_objects = frozenset(known_objects)
        self.max_datagram = int(max_datagram)
        self.bucket = TokenBucket(rate_hz, burst)
        self.counters = BridgeCounters()
        self._lock = threading.Lock()
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, recv_buffer)
            self._sock.bind((host, port))
        except (OSError, OverflowError) as exc:  # OverflowError: a port outside 0-65535
            self._sock.close()
            from .errors import DeviceError

            raise DeviceError(f"cannot listen for OSC on {host}:{port}: {getattr(exc, 'strerror', None) or exc}") from None
        self.remote = not ipaddress.ip_address(self._sock.getsockname()[0]).is_loopback
        if self.remote and not allow_remote:
            self._sock.close()
            raise HapticfxError(f"{host}:{port} listens beyond this machine, where anyone who can reach the port "
                                f"can play impacts; allow it explicitly (hapticfx serve --allow-remote) or bind "
                                f"127.0.0.1")
        self._sock.settimeout(0.1)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def address(self) -> tuple[str, int]:
        """The bound (host, port); port 0 at construction gives a free one."""
        return self._sock.getsockname()[:2]

    def handle(self, data: bytes, received_at: float, sender: str = "127.0.0.1") -> str | None:
        """Handle one datagram from ``sender`` (an IP address): a message, or a bundle of them, each counted;
        returns the first drop reason, or None when every message was accepted."""
        reasons = self._classify(data, received_at, sender)
        with self._lock:
            for reason in reasons:
                self.counters.received += 1
                if reason is None:
                    self.counters.accepted += 1
                else:
                    self.counters.dropped[reason] += 1
        return next((r for r in reasons if r is not None), None)

    def _classify(self, data: bytes, received_at: float, sender: str) -> list[str | None]:
        if len(data) > self.max_datagram:
            return ["oversize"]
        if not self.bucket.take():
            return ["rate_limited"]
        if not data.startswith(BUNDLE_HEAD):
            return [self._message(data, None, received_at, sender)]
        try:
            messages = split_bundle(data)
        except OscDecodeError as exc:
            return [exc.reason]
        allowed = 1 + self.bucket.take(len(messages) - 1)  # a token a message: a bundle is no way round the rate
        return [self._message(m, at, received_at, sender) if i < allowed else "rate_limited"
                for i, (m, at) in enumerate(messages)]

    def _message(self, data: bytes, at: float | None, received_at: float, sender: str) -> str | None:
        try:
            address, tags, args = decode_message(data)
            if address == IMPACT_ADDRESS:
                if self._secret_address is not None and not _loopback(sender):
                    return "unauthorized"
            elif address.endswith(IMPACT_ADDRESS) and address.count("/") == 3:  # /<secret>/hapticfx/impact
                if self._secret_address is None or not hmac.compare_digest(address.encode(), self._secret_address):
                    return "unauthorized"
            else:
                return "wrong_address"
            message = parse_impact(tags, args, at=at)
        except OscDecodeError as exc:
            return exc.reason
        if message.object not in self.known_objects:
            return "unknown_object"
        try:
            return None if self.submit(message, received_at) else "queue_full"
        except HapticfxError as exc:
            log.debug("engine refused %s: %s", message, exc)
            return "engine_refused"

    def serve_forever(self) -> None:
        """Receive until :meth:`stop`; returns then."""
        read_size = self.max_datagram + 1  # one byte more than allowed tells us it was oversize
        while not self._stop.is_set():
            try:
                data, (sender, _) = self._sock.recvfrom(read_size)
            except TimeoutError:
                continue
            except OSError as exc:  # e.g. ICMP-reported errors on some platforms: keep serving
                if self._stop.is_set():
                    break
                log.debug("recv failed: %s", exc)
                continue
            self.handle(data, time.perf_counter(), sender)

    def start(self) -> "OscBridge":
        """Serve on a daemon thread."""
        self._thread = threading.Thread(target=self.serve_forever, name="hapticfx-osc", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop receiving and close the socket."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
        self._sock.close()

    def stats(self) -> dict:
        """The counters, with the kernel's drop count for this socket where known."""
        with self._lock:
            if self._sock.fileno() >= 0:
                self.counters.kernel_dropped = _kernel_drops(self._sock)
            return self.counters.as_dict()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False
