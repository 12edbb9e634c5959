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

import heapq
import threading

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
        self._ends: list[int] = []  # heap: where each sounding impact ends (ring position)
        self._limiters: list[SafetyLimiter | None] = [None] * self.channels
        self._lock = threading.Lock()
        self._clock = 0  # frames rendered so far: the ring position of the next block
        self.refused = 0  # impacts not mixed in because max_voices were already sounding
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
        if self._limiters[channel] is None:
            raise SignalError(f"channel {channel} has no safety limits; call set_limits first")
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        if x.size > self._size // 2:
            x = x[: self._size // 2]
            self.truncated += 1
        with self._lock:
            self._prune()
            if len(self._ends) >= self.max_voices:
                self.refused += 1
                return False
            self._add_at(channel, self._clock, x)
            heapq.heappush(self._ends, self._clock + x.size)
        return True

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
