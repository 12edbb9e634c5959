"""Open Sound Control over UDP: the network bridge of ``hapticfx serve``.

One datagram is one OSC message (bundles are refused). The protocol is in
``docs/protocol.md``; the one message that renders is::

    /hapticfx/impact <object:s> <velocity:f|d|i> [<channel:i>] [<at:f|d>]

Every datagram that arrives is either handed to the engine or dropped, and
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

import logging
import math
import socket
import struct
import threading
import time
from dataclasses import dataclass, field
from typing import Callable

from .errors import HapticfxError
from .signal import MAX_VELOCITY_MPS

log = logging.getLogger(__name__)

IMPACT_ADDRESS = "/hapticfx/impact"

DROP_REASONS = (
    "oversize",        # longer than max_datagram bytes
    "rate_limited",    # over the token bucket (checked before any decoding)
    "not_osc",         # not a well-formed OSC 1.0 message
    "bundle",          # an OSC bundle ('#bundle'): not supported, send messages
    "wrong_address",   # a well-formed message to an address we do not serve
    "wrong_types",     # right address, type tags not one of the documented forms
    "bad_value",       # velocity negative, non-finite or above 100 m/s, channel < -1, non-finite time
    "unknown_object",  # object id not in the scene
    "queue_full",      # the engine's queue was full
    "engine_refused",  # the engine rejected it for another reason (closed, invalid)
)


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
    if data.startswith(b"#bundle\x00"):
        raise OscDecodeError("bundle", "OSC bundles are not supported")
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


def _osc_string(text: str) -> bytes:
    raw = text.encode("utf-8") + b"\x00"
    return raw + b"\x00" * (-len(raw) % 4)


def encode_impact(object: str, velocity: float) -> bytes:
    """The datagram ``/hapticfx/impact ,sf object velocity`` (for benchmarks and tools that send impacts)."""
    return _osc_string(IMPACT_ADDRESS) + _osc_string(",sf") + _osc_string(object) + struct.pack(">f", velocity)


@dataclass(frozen=True)
class ImpactMessage:
    """A decoded ``/hapticfx/impact``: object, velocity, optional channel and time."""

    object: str
    velocity: float
    channel: int | None = None
    at: float | None = None


_IMPACT_FORMS = {"sf", "sd", "si", "sfi", "sdi", "sii", "sfif", "sfid", "sdif", "sdid", "siif", "siid"}


def parse_impact(tags: str, args: list | None) -> ImpactMessage:
    """Check an ``/hapticfx/impact`` message's arguments; raises :class:`OscDecodeError`."""
    if args is None or tags not in _IMPACT_FORMS:
        raise OscDecodeError("wrong_types", f"type tags ',{tags}'; expected ',sf', ',sfi' or ',sfif'")
    obj, velocity = args[0], float(args[1])
    channel = args[2] if len(args) > 2 else -1
    at = float(args[3]) if len(args) > 3 else None
    if not math.isfinite(velocity) or not 0 <= velocity <= MAX_VELOCITY_MPS:
        raise OscDecodeError("bad_value", f"velocity {velocity:g} is not a finite number in [0, {MAX_VELOCITY_MPS:g}] m/s")
    if channel < -1:
        raise OscDecodeError("bad_value", f"channel {channel} (use -1 for the scene's channel)")
    if at is not None and not math.isfinite(at):
        raise OscDecodeError("bad_value", f"time {at} is not finite")
    return ImpactMessage(obj, velocity, None if channel == -1 else channel, at)


class TokenBucket:
    """At most ``rate_hz`` per second on average, ``burst`` at once. ``rate_hz == 0``: unlimited."""

    def __init__(self, rate_hz: float, burst: int, clock: Callable[[], float] = time.monotonic):
        self.rate_hz = float(rate_hz)
        self.burst = float(max(1, burst))
        self.tokens = self.burst
        self.clock = clock
        self.last = clock()

    def take(self) -> bool:
        if self.rate_hz <= 0:
            return True
        now = self.clock()
        self.tokens = min(self.burst, self.tokens + (now - self.last) * self.rate_hz)
        self.last = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        return False


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


class OscBridge:
    """Receives OSC datagrams on a UDP socket and submits impacts.

    ``submit(message, received_at)`` (usually :meth:`hapticfx.Engine.submit`)
    returns True when queued, False when the queue was full; it may raise a
    :class:`~hapticfx.errors.HapticfxError` for a message it refuses.
    ``known_objects`` are the scene's object ids. One receiving thread; a
    datagram is handled completely before the next is read, so the counters
    need no lock (readers get a consistent-enough snapshot via :meth:`stats`).
    """

    def __init__(self, submit: Submit, known_objects, *, host: str = "127.0.0.1", port: int = 9000,
                 max_datagram: int = 1024, rate_hz: float = 2000.0, burst: int = 500,
                 recv_buffer: int = 4 << 20):
        self.submit = submit
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
        self._sock.settimeout(0.1)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def address(self) -> tuple[str, int]:
        """The bound (host, port); port 0 at construction gives a free one."""
        return self._sock.getsockname()[:2]

    def handle(self, data: bytes, received_at: float) -> str | None:
        """Handle one datagram; returns the drop reason, or None when accepted."""
        reason = self._classify(data, received_at)
        with self._lock:
            self.counters.received += 1
            if reason is None:
                self.counters.accepted += 1
            else:
                self.counters.dropped[reason] += 1
        return reason

    def _classify(self, data: bytes, received_at: float) -> str | None:
        from .errors import HapticfxError

        if len(data) > self.max_datagram:
            return "oversize"
        if not self.bucket.take():
            return "rate_limited"
        try:
            address, tags, args = decode_message(data)
            if address != IMPACT_ADDRESS:
                return "wrong_address"
            message = parse_impact(tags, args)
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
                data = self._sock.recv(read_size)
            except TimeoutError:
                continue
            except OSError as exc:  # e.g. ICMP-reported errors on some platforms: keep serving
                if self._stop.is_set():
                    break
                log.debug("recv failed: %s", exc)
                continue
            self.handle(data, time.perf_counter())

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
