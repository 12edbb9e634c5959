"""The streaming mixer: overlapping impacts summed into one block stream.

:class:`Mixer` holds no device; a PortAudio callback (see
:mod:`hapticfx_soundcard.stream`) asks it for each block. An impact is summed
into a ring buffer per channel when it is added (on the caller's thread, a few
microseconds per thousand samples), so a block costs the same however many
impacts overlap: the callback copies ``frames`` samples out of the ring and runs
each sounding channel's safety limiter on them. The mixer keeps no impact's
samples once they are summed (only where each ends), so its memory is the ring,
whatever the count. At most ``max_voices`` impacts sound at once; one more is
refused and counted (``refused``).
"""

from __future__ import annotations

import bisect
import heapq
import threading

import numpy as np
from hapticfx.errors import SignalError
from hapticfx.interfaces import SafetyLimits
from hapticfx.safety import LimiterReport, SafetyLimiter

RING_S = 8.0  # the longest impact the ring holds; a longer one is cut (and counted)
DEFAULT_MAX_VOICES = 1000
# PulseAudio, around an underrun, was seen to cut up to 104 frames (2.2 ms at 48 kHz) out of a stream and
# join the rest without silence (a flood beside a CPU hog, the sink's monitor against the limiter's output):
# the limiters leave room for a cut this long in every RMS window (SafetyLimiter's `splice_s`).
SPLICE_S = 0.003


class Mixer:
    """Sums queued impacts per output channel, then limits each channel.

    Each channel has its own :class:`~hapticfx.safety.SafetyLimiter`, because two
    impacts that each passed the limiter can exceed it once added together.
    ``add`` is safe from any thread and returns at once; ``render_into`` never
    blocks for longer than a copy of one block.
    """

    def __init__(self, channels: int, rate_hz: float, *, max_voices: int = DEFAULT_MAX_VOICES, ring_s: float = RING_S):
        if channels < 1:
            raise SignalError(f"channels must be >= 1, got {channels}")
        if max_voices < 1:
            raise SignalError(f"max_voices must be >= 1, got {max_voices}")
        self.channels = int(channels)
        self.rate_hz = float(rate_hz)
        self.max_voices = int(max_voices)
        self._size = 1 << int(np.ceil(np.log2(max(1024, ring_s * self.rate_hz))))
        self._ring = np.zeros((self.channels, self._size))
        self._ends: list[int] = []  # heap: where each sounding impact ends (ring position)
        self._limiters: list[SafetyLimiter | None] = [None] * self.channels
        self._lock = threading.Lock()
        self._clock = 0  # frames rendered so far: the ring position of the next block
        self.refused = 0  # impacts not mixed in because max_voices were already sounding
        self.truncated = 0  # impacts longer than the ring, cut to its length
        self.rendered_frames = 0

    def set_limits(self, channel: int, limits: SafetyLimits) -> None:
        """Give ``channel`` its actuators' (effective, combined) safety limits; a channel that has a limiter
        already goes on from its state (what it sent stays in the windows)."""
        new = SafetyLimiter(limits, self.rate_hz, splice_s=SPLICE_S)
        with self._lock:
            old = self._limiters[channel]
            if old is not None:
                new.restore(old.state())
            self._limiters[channel] = new

    def widen(self, channels: int) -> None:
        """Allow ``channels`` output channels (a later actuator asked for a higher one)."""
        if channels > self.channels:
            with self._lock:
                self._ring = np.vstack([self._ring, np.zeros((channels - self.channels, self._size))])
                self._limiters.extend([None] * (channels - self.channels))
                self.channels = channels

    def _add_at(self, channel: int, start: int, samples: np.ndarray) -> None:
        first = start % self._size
        n1 = min(samples.size, self._size - first)
        self._ring[channel, first:first + n1] += samples[:n1]
        if n1 < samples.size:
            self._ring[channel, :samples.size - n1] += samples[n1:]

    def _prune(self) -> None:
        while self._ends and self._ends[0] <= self._clock:
            heapq.heappop(self._ends)

    def add(self, channel: int, samples: np.ndarray) -> bool:
        """Mix one impact (1D, normalised) into ``channel`` from the next block on; thread-safe.

        False (and counted in ``refused``) when ``max_voices`` impacts are sounding.
        """
        x = self._voice(channel, samples)
        with self._lock:
            if not self._room():
                return False
            self._place(channel, self._clock, x)
        return True

    def _voice(self, channel: int, samples: np.ndarray) -> np.ndarray:
        """One impact's samples, as the ring takes them (cut to half its length, counted)."""
        if self._limiters[channel] is None:
            raise SignalError(f"channel {channel} has no safety limits; call set_limits first")
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        if x.size > self._size // 2:
            x = x[: self._size // 2]
            self.truncated += 1
        return x

    def _room(self) -> bool:
        """Whether one more impact may sound (else it is counted in ``refused``); with the lock held."""
        self._prune()
        if len(self._ends) >= self.max_voices:
            self.refused += 1
            return False
        return True

    def _place(self, channel: int, start: int, x: np.ndarray) -> None:
        self._add_at(channel, start, x)
        heapq.heappush(self._ends, start + x.size)

    def clear(self) -> int:
        """Silence everything queued or sounding; returns how many impacts were cut."""
        with self._lock:
            self._prune()
            cut = len(self._ends)
            self._ends.clear()
            self._ring[:] = 0.0
        return cut

    @property
    def voices(self) -> int:
        """Impacts queued or still sounding."""
        with self._lock:
            self._prune()
            return len(self._ends)

    @property
    def busy(self) -> bool:
        """Whether any impact is queued or still sounding."""
        return self.voices > 0

    def render_into(self, out: np.ndarray) -> None:
        """Fill ``out`` (frames x channels, any float dtype) with the next block."""
        frames = out.shape[0]
        with self._lock:
            first = self._clock % self._size
            idx = np.arange(first, first + frames) % self._size if first + frames > self._size else \
                slice(first, first + frames)
            block = self._ring[:, idx].copy()
            self._ring[:, idx] = 0.0
            start_s = self._clock / self.rate_hz
            self._clock += frames
            self._prune()
        self.rendered_frames += frames
        out.fill(0.0)
        for ch in range(min(self.channels, out.shape[1])):
            if self._limiters[ch] is not None and block[ch].any():
                out[:, ch] = self._limiters[ch].process(block[ch], at_s=start_s)

    def report(self, channel: int) -> LimiterReport:
        """What the mixer's limiter on ``channel`` did so far."""
        limiter = self._limiters[channel]
        return limiter.report() if limiter is not None else LimiterReport()


# Frames a QueueMixer limits as one block; an impact starts at a quantum's start (1.3 ms at 48 kHz: on
# average 0.67 ms later than asked), because the limiter's gain is per block: a block limited again
# with a new impact in it would no longer match the part of it that was already sent.
QUANTUM = 64


class QueueMixer(Mixer):
    """A mixer for audio queued at the sound server well ahead of playback, which new impacts are mixed into.

    Positions are stream frames. :meth:`render` limits the next stretch after what was written, in
    whole quanta of ``QUANTUM`` frames. :meth:`add_at` mixes an impact in from the first quantum at
    or after a position that may already have been written, and returns the audio from there to the
    end of what was written, limited again, to be written over the queue. Each quantum is limited
    from the limiters' state at its start, kept while it is queued, so the audio limited again goes
    on from exactly what was already sent before it: the limits hold across the seam. :meth:`heard` says how far playback got;
    the mixer forgets what lies before.

    A write over the queue can land after the server has read past its start (a ``late`` write: the
    machine paused between working out the position and the write): the device then plays the earlier
    version up to some frame and the new one from there. So the mixer keeps, per position, the largest
    magnitude any version written there had (``_sent``), and limits the audio written again against it
    (:meth:`SafetyLimiter.process` ``floor``): the RMS limit holds wherever the switch falls, and after
    any number of writes over one stretch.
    """

    def __init__(self, channels: int, rate_hz: float, *, max_voices: int = DEFAULT_MAX_VOICES, ring_s: float = RING_S):
        super().__init__(channels, rate_hz, max_voices=max_voices, ring_s=ring_s)
        self._heard = 0  # frames played: an impact that ends before is over
        self._kept = 0  # the ring is zero before here, and limiter states are kept from here on
        # (start, stop, each limiter's states per quantum) of each run limited, tiling _kept.. _clock
        self._runs: list[tuple[int, int, list]] = []
        self._sent = np.zeros_like(self._ring)  # the largest |x| written at each position not yet heard

    def widen(self, channels: int) -> None:
        super().widen(channels)
        with self._lock:
            if self._sent.shape[0] < self.channels:
                self._sent = np.vstack([self._sent, np.zeros((self.channels - self._sent.shape[0], self._size))])

    def _prune(self) -> None:
        while self._ends and self._ends[0] <= self._heard:
            heapq.heappop(self._ends)

    def _limit(self, start: int, stop: int, *, again: bool) -> np.ndarray:
        """The limited audio of quanta ``start``..``stop`` (frames x channels, float32); with ``again``,
        from the limiters' state at ``start`` as it was when that quantum was first limited."""
        out = np.zeros((stop - start, self.channels), dtype=np.float32)
        limiters = [(ch, lim) for ch, lim in enumerate(self._limiters) if lim is not None]
        if again:
            run_start, _, states = self._runs[bisect.bisect_right(self._runs, start, key=lambda r: r[0]) - 1]
            for (ch, lim), kept in zip(limiters, states):
                lim.restore(kept[(start - run_start) // QUANTUM])
        first = start % self._size
        idx = slice(first, first + stop - start) if first + stop - start <= self._size else \
            np.arange(first, first + stop - start) % self._size
        quanta = range(start, stop, QUANTUM)
        per_channel = []
        for ch, lim in limiters:
            x = self._ring[ch, idx]
            if x.any():
                floor = self._sent[ch, idx] if again else None
                out[:, ch], states = lim.process_blocks(x, block=QUANTUM, at_s=start / self.rate_hz, floor=floor)
                self._sent[ch, idx] = np.abs(out[:, ch]) if floor is None else np.maximum(floor, np.abs(out[:, ch]))
            else:  # silence leaves the limiter as it is; its next block counts the gap
                states = [lim.state()] * len(quanta)
            per_channel.append(states)
        while self._runs and self._runs[-1][0] >= start:  # what is limited again replaces what was
            self._runs.pop()
        if self._runs and self._runs[-1][1] > start:
            self._runs[-1] = (self._runs[-1][0], start, self._runs[-1][2])
        self._runs.append((start, stop, per_channel))
        return out

    def render(self, frames: int) -> tuple[int, np.ndarray]:
        """At least ``frames`` more frames after what was written (whole quanta): ``(position, audio)``."""
        with self._lock:
            start = self._clock
            self._clock += -(-frames // QUANTUM) * QUANTUM
            audio = self._limit(start, self._clock, again=False)
        self.rendered_frames += audio.shape[0]
        return start, audio

    def add_at(self, channel: int, samples: np.ndarray, at: int) -> tuple[int, np.ndarray] | None:
        """Mix one impact (1D, normalised) into ``channel`` from the first quantum at or after stream
        frame ``at``; thread-safe.

        Returns ``(start, audio)``: what was written from the impact's start on, limited again with it
        in, to write over the queue. None when nothing from there on was written yet (it will be
        rendered with the impact in), or when ``max_voices`` impacts are sounding (counted in ``refused``).
        """
        x = self._voice(channel, samples)
        with self._lock:
            if not self._room():
                return None
            at = max(-(-int(at) // QUANTUM) * QUANTUM, self._kept)
            self._place(channel, at, x)
            if at >= self._clock:
                return None
            return at, self._limit(at, self._clock, again=True)

    def heard(self, frame: int) -> None:
        """Playback has reached stream frame ``frame``: what lies before it is forgotten."""
        with self._lock:
            self._heard = max(self._heard, int(frame))
            q = min(self._heard - self._heard % QUANTUM, self._clock)
            if q <= self._kept:
                return
            first, n = self._kept % self._size, q - self._kept
            for ring in (self._ring, self._sent):
                if n >= self._size:
                    ring[:] = 0.0
                elif first + n <= self._size:
                    ring[:, first:first + n] = 0.0
                else:
                    ring[:, first:] = 0.0
                    ring[:, :first + n - self._size] = 0.0
            while self._runs and self._runs[0][1] <= q:
                self._runs.pop(0)
            self._kept = q
            self._prune()

    def restart(self) -> int:
        """Forget everything for a new stream, whose positions start at 0; returns how many impacts were cut."""
        cut = self.clear()
        with self._lock:
            self._sent[:] = 0.0
            self._clock = self._heard = self._kept = 0
            self._runs.clear()
        return cut


class QueueProbe:
    """A :class:`QueueMixer` on one channel and the audio a server would end up playing from it, for the host's
    conformance check (:func:`hapticfx.conformance.check_mix_limiter`): the queue refilled in 5 ms requests
    150 ms ahead, each impact written over it, and every write landing late, after the server read past its
    start by up to 12.5 ms (the earlier version plays up to there)."""

    def __init__(self, limits: SafetyLimits, rate_hz: float, *, seed: int = 0):
        self.mixer = QueueMixer(1, rate_hz)
        self.mixer.set_limits(0, limits)
        self._request, self._queue = max(1, int(0.005 * rate_hz)), int(0.15 * rate_hz)
        self._late = max(1, int(0.0125 * rate_hz))
        self._rng = np.random.default_rng(seed)
        self._pending: list[tuple[int, np.ndarray]] = []

    def play(self, samples: np.ndarray, at_frame: int) -> None:
        self._pending.append((int(at_frame), np.asarray(samples, dtype=np.float64)))

    def output(self, frames: int) -> np.ndarray:
        played = np.zeros(frames + self.mixer._size, dtype=np.float32)
        pending = sorted(self._pending, key=lambda p: p[0])
        written = 0
        while written < frames:
            at, audio = self.mixer.render(self._request)
            played[at:at + audio.shape[0]] = audio[:, 0]
            written = at + audio.shape[0]
            playing = max(0, written - self._queue)
            self.mixer.heard(playing)
            while pending and pending[0][0] <= playing + self._queue // 2:
                start, x = pending.pop(0)
                back = self.mixer.add_at(0, x, max(start, playing))
                if back is not None:
                    first, audio = back
                    switch = min(first + audio.shape[0], first + int(self._rng.integers(0, self._late)))
                    played[switch:first + audio.shape[0]] = audio[switch - first:, 0]
        return played[:frames]
