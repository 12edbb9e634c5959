"""What the two kinds of sound-card stream share: one running stream per output, reserved
channel by channel, and outages: what sounded is counted as lost, ``play`` is refused
meanwhile, and the stream comes back by itself."""

from __future__ import annotations

import gc
import logging
import os
import sys
import threading
import time
from abc import ABC, abstractmethod
from collections import deque
from typing import Callable, Hashable

from hapticfx.errors import DeviceError
from hapticfx.interfaces import SafetyLimits
from hapticfx.ratelog import RateLimitedLog

log = logging.getLogger(__name__)

RETRY_S = 0.2  # between attempts to reopen a stream that stopped
UNDERFLOW_LOG_S = 10.0  # at most one underflow warning per stream in this time
SWITCH_INTERVAL_S = 0.001
GC_FREEZE_ENV = "HAPTICFX_GC_FREEZE"  # "0": leave the garbage collector as it is


def keep_the_gil_moving() -> None:
    """Keep the GIL from being held long while streams run (process-wide, idempotent).

    The audio callback is Python: it needs the GIL within a block's period (and an impact
    written over a queue needs it to be written on time). By default a thread doing Python
    work keeps the GIL 5 ms before it must hand it over; 1 ms keeps blocks on time. And a
    full garbage collection holds the GIL while it walks every tracked object (11-19 ms in
    ``hapticfx bench output``, longer than the 8.7 ms 'low' buffer: an underflow). So, once
    per process, the objects alive when the first stream opens (modules, classes, loaded
    effects) are moved out of the collector's reach (``gc.freeze``); later passes walk only
    what was made since. ``HAPTICFX_GC_FREEZE=0`` leaves the collector alone.
    """
    sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL_S))
    if gc.get_freeze_count() or os.environ.get(GC_FREEZE_ENV) == "0":
        return
    gc.collect()  # what is garbage now is freed, not frozen
    gc.freeze()


class SharedStream(ABC):
    """A stream shared by the actuators on its channels, its mixer, its underflows and its outages.

    Subclasses open the stream (:meth:`_open`), watch it (:meth:`_watch`, on a thread of its
    own), and call :meth:`_lose` when it fails and :meth:`_back` when it plays again.
    """

    queue_s = 0.0  # seconds queued at the server that impacts are written over (0: none)
    late = 0  # impacts written over a queue after the server had read their first frame
    reopen_on_resume = False  # a stalled stream that plays again is reopened rather than taken as it is

    def __init__(self, name: str, mixer, rate_hz: float, *, watchdog_s: float):
        self.name = name  # for messages: "sound output 'default'"
        self.mixer = mixer
        self.rate_hz = float(rate_hz)
        self.watchdog_s = watchdog_s
        self.home: Streams | None = None  # the registry that opened it
        self.physical: Hashable = name  # the output it plays into, however it was named (see claim())
        self.users: dict[int, list[SafetyLimits]] = {}  # channel -> the limits of each actuator on it
        self.underflows = 0
        self.underflow_times: deque[float] = deque(maxlen=1024)  # time.monotonic() of the latest ones
        # (time.monotonic(), gap) of the latest waits for the stream's feeder that were longer than it holds:
        # the stream went unfed that long, whether or not an underflow was reported.
        self.late_callbacks: deque[tuple[float, float]] = deque(maxlen=1024)
        self._underflow_log = RateLimitedLog(log, interval_s=UNDERFLOW_LOG_S)
        self._stop = threading.Event()
        self.outage: str | None = None  # why the output cannot play now
        self.outages = 0
        self.lost = 0  # impacts cut off by an outage
        self.downtime_s: list[float] = []  # how long each outage lasted, once over
        self._outage_since = 0.0
        self._last_attempt = 0.0
        self._state = threading.Lock()
        self._watchdog: threading.Thread | None = None

    def reserve(self, channel: int, limits: SafetyLimits) -> None:
        """Take ``channel`` for one more actuator with these limits; opens the stream (again, wider) as needed.

        Several actuators on one channel (two effects, two scenes or engines on one output) share its one
        limiter, which holds the strictest of their limits on their sum."""
        self._check_channel(channel)
        claim(self.physical, channel, self)
        self.mixer.widen(channel + 1)
        held = self.users.get(channel, [])
        self.mixer.set_limits(channel, limits.strictest(*held))
        try:
            if self._open_channels() < self.mixer.channels:
                self._open()
        except DeviceError:
            if not held:
                unclaim(self.physical, channel, self)
            raise
        self.users[channel] = held + [limits]  # only once it plays: a refused channel is not held
        if self._watchdog is None:
            self._watchdog = threading.Thread(target=self._watch, name=f"hapticfx-soundcard: {self.name}",
                                              daemon=True)
            self._watchdog.start()

    def release(self, channel: int, *, drain_timeout_s: float, limits: SafetyLimits | None = None) -> None:
        """Give ``channel`` back; the last actuator on the output closes the stream after draining it."""
        self.home.release(self, channel, drain_timeout_s=drain_timeout_s, limits=limits)

    def _check_channel(self, channel: int) -> None:
        """DeviceError if the output has no such channel."""

    @abstractmethod
    def _open_channels(self) -> int:
        """Channels of the stream as open now (0: not open)."""

    @abstractmethod
    def _open(self) -> None:
        """(Re)open the stream; DeviceError if the output refuses."""

    @abstractmethod
    def _watch(self) -> None:
        """The watchdog thread: outages, and the stream's own upkeep."""

    @abstractmethod
    def shutdown(self) -> None:
        """Stop the stream and its watchdog (does not wait for what is queued)."""

    @abstractmethod
    def play(self, channel: int, samples, *, received: float | None = None) -> None:
        """Mix one impact into ``channel``, received at ``received`` (``time.perf_counter()``; None: now);
        returns at once; DeviceError during an outage."""

    @abstractmethod
    def drain(self, timeout_s: float | None) -> None:
        """Wait until every queued impact has been heard; DeviceError on an outage or the timeout."""

    def _lose(self, why: str) -> None:
        with self._state:  # with play(): every impact is either cut here (and counted) or refused
            if self.outage is not None:
                return
            cut = self.mixer.clear()
            self.lost += cut
            self.outage = why
            self._outage_since = time.monotonic()
            self.outages += 1
        log.warning("%s unavailable: %s; %d impact(s) cut off; reconnecting", self.name, why, cut)

    def _back(self, how: str) -> None:
        with self._state:
            down = time.monotonic() - self._outage_since
            self.outage = None
            self._resumed()
        self.downtime_s.append(down)
        log.warning("%s is back after %.2f s (%s)", self.name, down, how)

    def _come_back(self, now: float, *, alive: bool, silent_s: float, period_s: float) -> None:
        """The watchdog's look during an outage: a stream still alive whose output plays again (it
        was heard from within two periods) is taken back (as it is, or reopened where
        ``reopen_on_resume``); a stopped one is reopened, every RETRY_S until the output answers."""
        if alive:
            if silent_s < 2 * period_s:
                if self.reopen_on_resume:
                    try:
                        self._open()
                    except DeviceError:
                        return
                self._back("the stream resumed")
            return  # still stalled; if the server dies meanwhile, the stream says so
        if now - self._last_attempt < RETRY_S:
            return
        self._last_attempt = now
        try:
            self._open()
        except DeviceError:
            return
        self._back("stream reopened")

    def _resumed(self) -> None:
        """Called as an outage ends, with the state lock held."""

    def check(self) -> None:
        """Raise :class:`DeviceError` while the output is unavailable."""
        why = self.outage
        if why is not None:
            raise DeviceError(f"{self.name} unavailable: {why}; reconnecting")

    def _wait_quiet(self, timeout_s: float | None) -> None:
        """Wait until the mixer has nothing left to play; DeviceError on an outage or the timeout."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while self.mixer.busy:
            self.check()
            if deadline is not None and time.monotonic() > deadline:
                raise DeviceError(f"{self.name} did not finish playing within {timeout_s:g} s")
            time.sleep(0.005)
        self.check()


_claims: dict[tuple[Hashable, int], SharedStream] = {}  # (physical output, channel) -> the stream playing it
_claims_lock = threading.Lock()


def claim(physical: Hashable, channel: int, stream: SharedStream) -> None:
    """Record that ``stream`` plays ``channel`` of ``physical``; :class:`DeviceError` if another stream of this
    process already does: each would limit only its own part of the sum that reaches the actuator."""
    with _claims_lock:
        other = _claims.setdefault((physical, channel), stream)
        if other is not stream and other._stop.is_set():  # a stream shut down since: its claim is void
            other = _claims[(physical, channel)] = stream
    if other is not stream:
        raise DeviceError(f"{stream.name} channel {channel}: {other.name} already plays that output and channel "
                          "here; each would limit only its own part of the sum: give both the same `queue`")


def unclaim(physical: Hashable, channel: int, stream: SharedStream) -> None:
    with _claims_lock:
        if _claims.get((physical, channel)) is stream:
            del _claims[(physical, channel)]


class Streams:
    """The running streams, one per output (``key``), each shared by the actuators on its channels."""

    def __init__(self):
        self._streams: dict[Hashable, SharedStream] = {}
        self._lock = threading.Lock()

    def acquire(self, key: Hashable, make: Callable[[], SharedStream], *, channel: int, rate_hz: float,
                limits: SafetyLimits) -> SharedStream:
        """The stream of ``key`` (the physical output it plays into) with ``channel`` reserved; ``make()``
        opens it on first use (the first actuator on an output sets its options)."""
        with self._lock:
            stream = self._streams.get(key)
            if stream is None:
                keep_the_gil_moving()
                stream = self._streams[key] = make()
                stream.home = self
                stream.physical = key
            elif stream.rate_hz != rate_hz:
                raise DeviceError(f"{stream.name} already streams at {stream.rate_hz:g} Hz for another actuator; "
                                  f"give both the same rate_hz")
            try:
                stream.reserve(channel, limits)
            except DeviceError:
                if not stream.users:
                    stream.shutdown()
                    self._streams.pop(key, None)
                raise
            return stream

    def release(self, stream: SharedStream, channel: int, *, drain_timeout_s: float,
                limits: SafetyLimits | None = None) -> None:
        """Give ``channel`` back; the last actuator on an output closes its stream after draining it."""
        with self._lock:
            held = stream.users.get(channel, [])
            mine = [i for i, h in enumerate(held) if h is limits]  # by identity: equal values may carry other `also`
            if mine or held:
                held.pop(mine[0] if mine else -1)
            if held:
                stream.mixer.set_limits(channel, held[0].strictest(*held[1:]))
            else:
                stream.users.pop(channel, None)
                unclaim(stream.physical, channel, stream)
            last = not stream.users
            if last:
                self._streams = {k: s for k, s in self._streams.items() if s is not stream}
        if last:
            try:
                if stream.outage is None:
                    stream.drain(drain_timeout_s)
            finally:
                stream.shutdown()

    def shutdown_all(self) -> None:
        """Close every stream (at exit)."""
        with self._lock:
            running = list(self._streams.values())
            self._streams.clear()
        for stream in running:
            stream.shutdown()
