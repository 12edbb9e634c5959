"""One PortAudio output stream per device, shared by the actuators on its channels.

The stream's callback asks a :class:`~hapticfx_soundcard.mixer.Mixer` for each
block. A watchdog thread and PortAudio's finished callback turn a stream that
stalls or stops on its own (sound server stalled, killed or restarted, device
removed) into an *outage* within ``watchdog_s``: what was still sounding is
counted as lost, and until the device is back every ``play`` raises
:class:`DeviceError` at once (the engine counts those impacts as failed). The
watchdog then brings the output back: a stalled stream that resumes, or one that
stopped, is reopened (the latter every ``RETRY_S``, until the device answers). Nothing
waits on a dead stream.

A stream that underflows after its start is reopened with a longer buffer, up to
``max_latency``: at least twice the one it had, and long enough for the longest wait
between two audio callbacks that was seen (the machine not running its feeder). The
switch waits until the mixer has been silent for longer than the old buffer (at most
``GROW_WAIT_S``), so that it cuts off nothing: what the old stream still held is
dropped with it. Sound servers do the same with their own buffers (PulseAudio raises
its wake-up watermark after an underrun).
"""

from __future__ import annotations

import logging
import threading
import time

import numpy as np
from hapticfx.errors import DeviceError
from hapticfx.interfaces import SafetyLimits

from .devices import OutputDevice, import_sounddevice
from .mixer import Mixer
from .noise import FILTER
from .shared import SharedStream, Streams

log = logging.getLogger(__name__)

START_S = 0.25  # an underflow this soon after a stream starts is its start (seen at +15 ms), not a gap in the sound
GROW_WAIT_S = 1.0  # a longer buffer waits this long at most for silence before it is switched in
GROW_MARGIN = 1.5  # a lengthened buffer holds this many times the longest wait between callbacks

_streams = Streams()  # by the physical output they play into (devices.physical_output)


def acquire(device: OutputDevice, physical, *, channel: int, rate_hz: float, limits: SafetyLimits,
            latency: str | float, max_latency: float, blocksize: int, max_voices: int,
            watchdog_s: float) -> "DeviceStream":
    """The running stream of ``device`` with ``channel`` reserved (opened on first use).

    The first actuator on a device sets the stream's latency (and the longest it may grow to), block size
    and voice count.
    """
    def make():
        return DeviceStream(device, rate_hz, latency=latency, max_latency=max_latency, blocksize=blocksize,
                            max_voices=max_voices, watchdog_s=watchdog_s)

    return _streams.acquire(physical, make, channel=channel, rate_hz=rate_hz, limits=limits)


def _abort(stream, *, wait_s: float) -> bool:
    """Abort and close ``stream`` without waiting more than ``wait_s``; True if it closed.

    On a stalled sound server PortAudio's abort can block for good. Then the
    stream is left to the OS, and sounddevice's exit handler (which would wait on
    it in Pa_Terminate and hang the program's exit) is unregistered.
    """
    def run():
        try:
            stream.abort()
            stream.close()
        except Exception:  # the device may already be gone; there is nothing left to release
            pass

    closer = threading.Thread(target=run, name="hapticfx-soundcard-abort", daemon=True)
    closer.start()
    closer.join(timeout=wait_s)
    if closer.is_alive():
        import atexit

        atexit.unregister(import_sounddevice()._exit_handler)
        return False
    return True


class DeviceStream(SharedStream):
    """A running output stream on one device, mixing impacts on its channels, reopened after an outage."""

    # Beside stress-ng --cpu 2, a click played on a PortAudio stream taken back as it was after the server
    # had stopped for 1 s went unheard in 1 of 4 runs; on a stream reopened at once, 6 of 6 were heard.
    reopen_on_resume = True

    def __init__(self, device: OutputDevice, rate_hz: float, *, latency: str | float, max_latency: float,
                 blocksize: int, max_voices: int, watchdog_s: float):
        super().__init__(f"sound output {device.name!r}", Mixer(min(2, device.channels), rate_hz,
                                                                 max_voices=max_voices), rate_hz,
                         watchdog_s=watchdog_s)
        self.device = device
        self.latency = latency
        self.max_latency_s = max_latency  # the buffer may be lengthened up to this after underflows (0: never)
        self.buffer_changes: list[tuple[float, float, float]] = []  # (time.monotonic(), from_s, to_s)
        self._grow_to = 0.0  # a longer buffer waiting for silence to be switched in (0: none)
        self._grow_since = 0.0
        self.blocksize = blocksize
        self._buffer_s = float("nan")  # as PortAudio reported it when the stream last opened
        self._longest_gap_s = 0.0  # since the last underflow warning: how long a buffer would have held
        self._underflows_told = 0
        self._started = 0.0
        self._last_callback = time.monotonic()
        self._generation = 0  # callbacks of a stream this one replaced are ignored
        self._stream = None
        self._filtering = False

    # --- lifetime -------------------------------------------------------------------

    def _check_channel(self, channel: int) -> None:
        if channel >= self.device.channels:
            raise DeviceError(
                f"sound output {self.device.name!r} has {self.device.channels} channel(s); "
                f"channel {channel} does not exist (channels count from 0)"
            )

    def _open_channels(self) -> int:
        return 0 if self._stream is None else self._stream.channels

    def _open(self) -> None:
        """(Re)open the stream; DeviceError if the device refuses."""
        sd = import_sounddevice()
        if not self._filtering:
            FILTER.acquire()
            self._filtering = True
        old, self._stream = self._stream, None
        with self._state:
            self._generation += 1
            generation = self._generation
        if old is not None:
            _abort(old, wait_s=1.0)
        try:
            stream = sd.OutputStream(
                device=self.device.index, samplerate=self.rate_hz, channels=self.mixer.channels,
                dtype="float32", latency=self.latency, blocksize=self.blocksize,
                callback=lambda *a: self._callback(generation, *a),
                finished_callback=lambda: self._finished(generation),
            )
            self._buffer_s = float(stream.latency)
            self._last_callback = self._started = time.monotonic()
            stream.start()
        except sd.PortAudioError as exc:
            raise DeviceError(f"cannot open sound output {self.device.name!r}: {exc}") from None
        self._stream = stream

    def shutdown(self) -> None:
        """Stop the stream and the watchdog (does not wait for queued impacts)."""
        self._stop.set()
        self._underflow_log.flush()
        with self._state:
            self._generation += 1  # its finished callback is ours, not an outage
        if self._stream is not None:
            _abort(self._stream, wait_s=1.0)
            self._stream = None
        if self._filtering:
            self._filtering = False
            FILTER.release()

    # --- real-time side -------------------------------------------------------------

    def _callback(self, generation: int, outdata: np.ndarray, frames: int, time_info, status) -> None:
        if generation != self._generation:
            outdata.fill(0.0)
            return
        now = time.monotonic()
        gap, self._last_callback = now - self._last_callback, now
        if gap > self._buffer_s:
            self.late_callbacks.append((now, gap))
            self._longest_gap_s = max(self._longest_gap_s, gap)
        if status.output_underflow:
            self.underflows += 1
            self.underflow_times.append(now)
        self.mixer.render_into(outdata)

    def _finished(self, generation: int) -> None:
        if generation == self._generation and not self._stop.is_set():
            self._lose("the sound stream stopped by itself (sound server gone or device removed)")

    # --- outages --------------------------------------------------------------------

    def _resumed(self) -> None:
        # the underflows of the return are the outage's, told already: the stream starts again
        self._started = time.monotonic()

    def _tell_underflows(self, now: float) -> None:
        """Warn (at a bounded rate) of underflows since the last look, other than a stream's start,
        and plan a longer buffer where ``max_latency`` allows one."""
        new = self.underflows - self._underflows_told
        if not new:
            return
        self._underflows_told = self.underflows
        gap, self._longest_gap_s = self._longest_gap_s, 0.0
        if now - self._started <= START_S:
            return
        waited = f"; the longest wait between two audio callbacks was {gap * 1e3:.1f} ms" if gap else ""
        grow_to = min(self.max_latency_s, max(2 * self._buffer_s, GROW_MARGIN * gap, self._grow_to))
        if grow_to > self._buffer_s + 0.0005:
            if not self._grow_to:
                self._grow_since = now
            self._grow_to = grow_to
            remedy = (f"lengthening it to {grow_to * 1e3:.1f} ms (max_latency: {self.max_latency_s:g}) "
                      f"when nothing sounds")
        else:
            remedy = ("if they go on, give the actuator a longer latency or max_latency (e.g. latency: 0.03) "
                      "or run less beside it")
        self._underflow_log.event("underflow", (
            f"sound output {self.device.name!r}: {new} underflow(s), gaps in the sound (its buffer holds "
            f"{self._buffer_s * 1e3:.1f} ms and was not refilled in time{waited}); {remedy}"))

    def _grow(self, now: float) -> None:
        """Reopen the stream with the longer buffer planned by :meth:`_tell_underflows`."""
        was, self.latency, self._grow_to = self._buffer_s, self._grow_to, 0.0
        try:
            self._open()
        except DeviceError as exc:
            self._lose(f"reopening it with a {self.latency * 1e3:.1f} ms buffer failed ({exc})")
            return
        self.buffer_changes.append((now, was, self._buffer_s))
        log.warning("sound output %r: buffer lengthened from %.1f to %.1f ms after underflows",
                    self.device.name, was * 1e3, self._buffer_s * 1e3)

    def _watch(self) -> None:
        period = min(0.05, self.watchdog_s / 4)
        quiet_since = None  # since when the mixer has had nothing to play, while a longer buffer waits
        while not self._stop.wait(period):
            now = time.monotonic()
            silent = now - self._last_callback
            if self.outage is None:
                if silent > self.watchdog_s:
                    self._lose(f"no audio callback for {silent:.2f} s (sound server stalled or gone)")
                self._tell_underflows(now)
                quiet_since = None if not self._grow_to or self.mixer.busy else quiet_since or now
                if self._grow_to and self.outage is None and (
                        (quiet_since and now - quiet_since > self._buffer_s) or now - self._grow_since > GROW_WAIT_S):
                    self._grow(now)
                continue
            stream = self._stream
            self._come_back(now, alive=stream is not None and stream.active, silent_s=silent, period_s=period)

    # --- caller side ----------------------------------------------------------------

    def play(self, channel: int, samples: np.ndarray, *, received: float | None = None) -> None:
        # `received` is not used: an impact can start no earlier than the next block, behind the buffer
        with self._state:
            self.check()
            self.mixer.add(channel, samples)

    def drain(self, timeout_s: float | None) -> None:
        """Wait until every queued impact has left the device (its output latency included)."""
        self._wait_quiet(timeout_s)
        stream = self._stream
        if stream is not None:
            time.sleep(float(stream.latency) + 2 * max(stream.blocksize, 256) / self.rate_hz)
        self.check()

    @property
    def output_latency_s(self) -> float:
        """The stream's output latency in seconds, as PortAudio reported it when the stream last
        opened: the old one while a longer buffer is being switched in (NaN before the first)."""
        return self._buffer_s
