"""The streaming mixer: overlapping impacts summed into one block stream.

:class:`Mixer` holds no device; a PortAudio callback (see
:mod:`hapticfx_soundcard.stream`) asks it for each block. An impact is summed
into a ring buffer per channel when it is added (on the caller's thread, a few
microseconds per thousand samples), so a block costs the same however many
impacts overlap: the callback copies ``frames`` samples out of the ring and runs
each sounding channel's safety limiter on them. At most ``max_voices`` impacts
sound at once; a new one beyond that takes the place of the oldest, whose rest
is subtracted from the ring.
"""

from __future__ import annotations

import threading
from collections import deque

import numpy as np
from hapticfx.errors import SignalError
from hapticfx.interfaces import SafetyLimits
from hapticfx.safety import LimiterReport, SafetyLimiter

RING_S = 8.0  # the longest impact the ring holds; a longer one is cut (and counted)
DEFAULT_MAX_VOICES = 1000


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
        self._voices: deque[tuple[int, int, int, np.ndarray]] = deque()  # (start, end, channel, samples)
        self._limiters: list[SafetyLimiter | None] = [None] * self.channels
        self._lock = threading.Lock()
        self._clock = 0  # frames rendered so far: the ring position of the next block
        self.stolen = 0  # impacts cut short because max_voices were already sounding
        self.truncated = 0  # impacts longer than the ring, cut to its length
        self.rendered_frames = 0

    def set_limits(self, channel: int, limits: SafetyLimits) -> None:
        """Give ``channel`` its actuator's (effective) safety limits; before its first impact."""
        self._limiters[channel] = SafetyLimiter(limits, self.rate_hz)

    def widen(self, channels: int) -> None:
        """Allow ``channels`` output channels (a later actuator asked for a higher one)."""
        if channels > self.channels:
            with self._lock:
                self._ring = np.vstack([self._ring, np.zeros((channels - self.channels, self._size))])
                self._limiters.extend([None] * (channels - self.channels))
                self.channels = channels

    def _add_at(self, channel: int, start: int, samples: np.ndarray, sign: float) -> None:
        first = start % self._size
        n1 = min(samples.size, self._size - first)
        self._ring[channel, first:first + n1] += sign * samples[:n1]
        if n1 < samples.size:
            self._ring[channel, :samples.size - n1] += sign * samples[n1:]

    def add(self, channel: int, samples: np.ndarray) -> None:
        """Queue one impact (1D, normalised) on ``channel``; it starts with the next block."""
        if self._limiters[channel] is None:
            raise SignalError(f"channel {channel} has no safety limits; call set_limits first")
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        if x.size > self._size // 2:
            x = x[: self._size // 2]
            self.truncated += 1
        with self._lock:
            start = self._clock
            self._add_at(channel, start, x, 1.0)
            self._voices.append((start, start + x.size, channel, x))
            if len(self._voices) > self.max_voices:  # drop those already over, then steal the oldest
                self._voices = deque(v for v in self._voices if v[1] > self._clock)
            if len(self._voices) > self.max_voices:
                old_start, old_end, old_channel, old = self._voices.popleft()
                done = self._clock - old_start
                if done < old.size:
                    self._add_at(old_channel, self._clock, old[done:], -1.0)
                self.stolen += 1

    def clear(self) -> int:
        """Silence everything queued or sounding; returns how many impacts were cut."""
        with self._lock:
            cut = sum(1 for _, end, _, _ in self._voices if end > self._clock)
            self._voices.clear()
            self._ring[:] = 0.0
        return cut

    @property
    def voices(self) -> int:
        """Impacts queued or still sounding."""
        with self._lock:
            return sum(1 for _, end, _, _ in self._voices if end > self._clock)

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
            while self._voices and self._voices[0][1] <= self._clock:
                self._voices.popleft()
        self.rendered_frames += frames
        out.fill(0.0)
        for ch in range(min(self.channels, out.shape[1])):
            if self._limiters[ch] is not None and block[ch].any():
                out[:, ch] = self._limiters[ch].process(block[ch], at_s=start_s)

    def report(self, channel: int) -> LimiterReport:
        """What the mixer's limiter on ``channel`` did so far."""
        limiter = self._limiters[channel]
        return limiter.report() if limiter is not None else LimiterReport()
