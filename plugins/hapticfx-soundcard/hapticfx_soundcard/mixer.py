"""The streaming mixer: overlapping impacts summed into one block stream.

:class:`Mixer` holds no device; a PortAudio callback (see
:mod:`hapticfx_soundcard.stream`) asks it for each block. ``add`` is safe to
call from any thread and returns at once; ``render_into`` never blocks and
keeps at most ``max_voices`` impacts (queued or sounding), replacing the
oldest when full, so memory stays bounded however fast impacts arrive.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from hapticfx.errors import SignalError
from hapticfx.interfaces import SafetyLimits
from hapticfx.safety import LimiterReport, SafetyLimiter


class _Voice:
    __slots__ = ("channel", "samples", "pos")

    def __init__(self, channel: int, samples: np.ndarray):
        self.channel = channel
        self.samples = samples
        self.pos = 0


class Mixer:
    """Sums queued impacts per output channel, then limits each channel.

    Each channel has its own :class:`~hapticfx.safety.SafetyLimiter`, because two
    impacts that each passed the limiter can exceed it once added together.
    """

    def __init__(self, channels: int, rate_hz: float, *, max_voices: int = 64):
        if channels < 1:
            raise SignalError(f"channels must be >= 1, got {channels}")
        if max_voices < 1:
            raise SignalError(f"max_voices must be >= 1, got {max_voices}")
        self.channels = int(channels)
        self.rate_hz = float(rate_hz)
        self.max_voices = int(max_voices)
        # Bounded: impacts queued faster than blocks are rendered push out the oldest queued.
        self._incoming: deque[_Voice] = deque(maxlen=self.max_voices)
        self._active: list[_Voice] = []
        self._limiters: list[SafetyLimiter | None] = [None] * self.channels
        self._clock = 0  # frames rendered so far
        self.stolen = 0  # impacts cut short because max_voices were already sounding
        self.rendered_frames = 0

    def set_limits(self, channel: int, limits: SafetyLimits) -> None:
        """Give ``channel`` its actuator's (effective) safety limits; before its first impact."""
        self._limiters[channel] = SafetyLimiter(limits, self.rate_hz)

    def widen(self, channels: int) -> None:
        """Allow ``channels`` output channels (a later actuator asked for a higher one)."""
        if channels > self.channels:
            self._limiters.extend([None] * (channels - self.channels))
            self.channels = channels

    def add(self, channel: int, samples: np.ndarray) -> None:
        """Queue one impact (1D, normalised) on ``channel``; thread-safe, returns at once."""
        if self._limiters[channel] is None:
            raise SignalError(f"channel {channel} has no safety limits; call set_limits first")
        if len(self._incoming) == self.max_voices:
            self.stolen += 1
        self._incoming.append(_Voice(channel, np.ascontiguousarray(samples, dtype=np.float64)))

    @property
    def busy(self) -> bool:
        """Whether any impact is queued or still sounding."""
        return bool(self._incoming) or bool(self._active)

    def render_into(self, out: np.ndarray) -> None:
        """Fill ``out`` (frames x channels, any float dtype) with the next block."""
        frames = out.shape[0]
        out.fill(0.0)
        while self._incoming:
            voice = self._incoming.popleft()
            if len(self._active) >= self.max_voices:
                self._active.pop(0)
                self.stolen += 1
            self._active.append(voice)
        start_s = self._clock / self.rate_hz
        self._clock += frames
        self.rendered_frames += frames
        if not self._active:
            return
        mix = np.zeros((self.channels, frames))
        used = [False] * self.channels
        alive = []
        for voice in self._active:
            n = min(frames, voice.samples.shape[0] - voice.pos)
            mix[voice.channel, :n] += voice.samples[voice.pos:voice.pos + n]
            used[voice.channel] = True
            voice.pos += n
            if voice.pos < voice.samples.shape[0]:
                alive.append(voice)
        self._active = alive
        for ch in range(min(self.channels, out.shape[1])):
            if used[ch]:
                out[:, ch] = self._limiters[ch].process(mix[ch], at_s=start_s)

    def report(self, channel: int) -> LimiterReport:
        """What the mixer's limiter on ``channel`` did so far."""
        limiter = self._limiters[channel]
        return limiter.report() if limiter is not None else LimiterReport()
