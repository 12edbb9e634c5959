"""A deep queue at the PulseAudio server, with each new impact written over it just ahead of playback.

Through PortAudio a stream's buffer is its latency: a new impact queues behind
everything already buffered, so a buffer long enough to ride through a stall
of the machine (40-66 ms here, docs/benchmarks.md) delays every impact as much.
This stream keeps ``queue`` seconds queued at the server, so a stall shorter
than that leaves the sound unbroken, and writes each new impact over the queued
audio ``ahead`` seconds before the frame being heard (libpulse's absolute seek):
its latency is ``ahead``, not ``queue``. An impact handed over with the time it
was received (the engine does) is written ``ahead`` after that time, so the time
it took to render adds nothing, as long as that still leaves ``SOONEST_S`` before
playback. The queue is refilled on libpulse's thread every few milliseconds; that
callback is Python too, but it has until the queue runs dry to get the GIL, not a
block's period.

Every impact goes through the channel's safety limiter: the mixer limits the
queued audio again from the impact's start, from the limiters' state there
(:class:`~hapticfx_soundcard.mixer.QueueMixer`). An impact whose first frame the
server had already read when the write arrived counts as ``late``.

Outages are handled as :class:`~hapticfx_soundcard.stream.DeviceStream` does: a
server that stops asking for audio for ``watchdog_s`` or drops the connection is
an outage (what was sounding is counted as lost, ``play`` raises
:class:`DeviceError`), a stalled server that resumes is taken back as it is, and
a gone one is reconnected every ``RETRY_S``.
"""

from __future__ import annotations

import atexit
import logging
import time

import numpy as np
from hapticfx.errors import DeviceError
from hapticfx.interfaces import SafetyLimits

from .libpulse import Playback, sink_info
from .mixer import QueueMixer
from .shared import SharedStream, Streams

log = logging.getLogger(__name__)

REQUEST_S = 0.005  # the server asks for more audio whenever this much was played (minreq)
# An impact that took a while to render is still written at least this far ahead of playback (or `ahead`, if
# shorter): the server's read index ran up to 4.0 ms ahead of the playing position (docs/soundcard.md).
SOONEST_S = 0.005
CHANNELS = 2  # the stream's channels to start with (the paper's two voice-coil actuators); more reopen it

_streams = Streams()  # by the sink they play into
atexit.register(_streams.shutdown_all)  # libpulse's thread calls into Python: it must go before the interpreter does


def acquire(sink: str | None, *, channel: int, limits: SafetyLimits, queue_s: float,
            ahead_s: float, max_voices: int, watchdog_s: float) -> "QueueStream":
    """The queue stream on ``sink`` (None: the server's default) with ``channel`` reserved (opened on
    first use; the first actuator on a sink sets its queue, lead and voice count).

    Streams are kept by the sink they resolve to, so the default sink named ``default`` and by its own
    name is one stream with one limiter per channel; and a stream runs at the sink's rate, so the server
    resamples nothing after the limiter (an impact at another rate is resampled before it is mixed)."""
    name, rate_hz = sink_info(sink)

    def make():
        return QueueStream(name, rate_hz, default=sink is None, queue_s=queue_s, ahead_s=ahead_s, max_voices=max_voices,
                           watchdog_s=watchdog_s)

    return _streams.acquire(physical_sink(name), make, channel=channel, rate_hz=rate_hz, limits=limits)


def physical_sink(name: str) -> tuple[str, str]:
    """The key of a PulseAudio sink among physical outputs (shared with PortAudio devices that play into it)."""
    return ("pulse", name)


class QueueStream(SharedStream):
    """A PulseAudio playback stream holding ``queue_s`` of audio, new impacts written ``ahead_s`` before
    playback, shared by the actuators on its channels and reconnected after an outage."""

    def __init__(self, sink: str | None, rate_hz: float, *, queue_s: float, ahead_s: float, max_voices: int,
                 watchdog_s: float, default: bool = False):
        if not ahead_s < queue_s:
            raise DeviceError(f"a queue of {queue_s:g} s cannot take impacts {ahead_s:g} s ahead of playback; "
                              "give queue more than ahead")
        super().__init__(f"PulseAudio sink {sink!r}" if sink and not default else "the PulseAudio default sink",
                         QueueMixer(CHANNELS, rate_hz, max_voices=max_voices), rate_hz, watchdog_s=watchdog_s)
        self.sink = sink
        self.queue_s, self.ahead_s = float(queue_s), float(ahead_s)
        self._ahead = int(round(ahead_s * self.rate_hz))
        self._soonest = int(round(min(ahead_s, SOONEST_S) * self.rate_hz))
        self.buffer_changes: list[tuple[float, float, float]] = []  # the queue is never lengthened
        self.late = 0  # impacts whose first frame the server had read before their write came
        self._last_request = time.monotonic()
        self._playback: Playback | None = None

    # --- lifetime -------------------------------------------------------------------

    def _open_channels(self) -> int:
        return 0 if self._playback is None else self._playback.channels

    def _open(self) -> None:
        """(Re)connect; :class:`DeviceError` if the server or the sink refuses."""
        with self._state:
            old, self._playback = self._playback, None
        if old is not None:
            old.close()
        self.mixer.restart()  # the new stream's positions start at 0
        self._last_request = time.monotonic()
        playback = Playback(
            rate_hz=self.rate_hz, channels=self.mixer.channels, sink=self.sink, name="hapticfx",
            queue_frames=int(round(self.queue_s * self.rate_hz)), request_frames=int(round(REQUEST_S * self.rate_hz)),
            on_request=self._request, on_underflow=self._underflow, on_failure=self._lose,
        )
        with self._state:
            self._playback = playback

    def shutdown(self) -> None:
        """Leave the server and stop the watchdog (does not wait for queued impacts)."""
        self._stop.set()
        self._underflow_log.flush()
        playback, self._playback = self._playback, None
        if playback is not None:
            playback.close()

    # --- on libpulse's thread -------------------------------------------------------

    def _request(self, playback: Playback, frames: int) -> None:
        now = time.monotonic()
        gap, self._last_request = now - self._last_request, now
        if gap > self.queue_s - self.ahead_s:  # less than `ahead` was left queued: nearly dry
            self.late_callbacks.append((now, gap))
        if frames <= 0 or playback.channels != self.mixer.channels:  # widened: this stream is being replaced
            return
        self.mixer.heard(playback.playing_frame())
        at, audio = self.mixer.render(frames)
        playback.write(audio, at)

    def _underflow(self) -> None:
        self.underflows += 1
        self.underflow_times.append(time.monotonic())

    # --- outages --------------------------------------------------------------------

    def _watch(self) -> None:
        period = min(0.05, self.watchdog_s / 4)
        told = 0
        while not self._stop.wait(period):
            now = time.monotonic()
            silent = now - self._last_request
            if self.underflows > told:
                self._underflow_log.event("underflow", (
                    f"{self.name}: {self.underflows - told} underflow(s), gaps in the sound: the queue of "
                    f"{self.queue_s * 1e3:.0f} ms ran dry; if they go on, give the actuator a longer queue"))
                told = self.underflows
            if self.outage is None:
                if silent > self.watchdog_s:
                    self._lose(f"no request for audio for {silent:.2f} s (sound server stalled)")
                continue
            playback = self._playback
            self._come_back(now, alive=playback is not None and not playback.failed, silent_s=silent, period_s=period)

    # --- caller side ----------------------------------------------------------------

    def play(self, channel: int, samples: np.ndarray, *, received: float | None = None) -> None:
        """Write one impact over the queue ``ahead`` after ``received`` (``time.perf_counter()``; None: now),
        so that the time it took to render does not add to its latency; at least ``SOONEST_S`` (or
        ``ahead``) ahead of playback."""
        playback = self._playback
        if playback is None:
            self.check()
            raise DeviceError(f"{self.name} is being reconnected")
        # libpulse's lock before ours: its thread takes them in that order when the server fails
        with playback.locked(), self._state:
            self.check()
            if playback is not self._playback:
                raise DeviceError(f"{self.name} is being reconnected")
            written = self.mixer.add_at(channel, samples, self._position(playback.playing_frame(), received))
            if written is not None:
                start, audio = written
                playback.write(audio, start)
                playback.read_index_then(lambda read: self._landed(start, read))

    def _position(self, playing: int, received: float | None) -> int:
        """Where an impact received at ``received`` goes, with frame ``playing`` being heard now."""
        if received is None:
            return playing + self._ahead
        since = max(0.0, time.perf_counter() - received)
        return max(playing + self._soonest, playing + self._ahead - int(since * self.rate_hz))

    def _landed(self, start: int, read: int) -> None:
        if read > start:
            self.late += 1

    def drain(self, timeout_s: float | None) -> None:
        """Wait until every queued impact has been played (its lead included)."""
        self._wait_quiet(timeout_s)

    @property
    def output_latency_s(self) -> float:
        """How far ahead of playback a new impact is written: its latency."""
        return self.ahead_s
