"""The parametric description that envelope formats hold, and its curves sampled for playing.

Every envelope format here (``.haptic``, AHAP, Android envelopes, ``.hjif`` vectorial
bands) describes an impact the way Meta's ``.haptic`` 1.0 does: an amplitude envelope
(breakpoints, 0-1 of full scale, linear between them), a frequency envelope (0-1, mapped
to Hz by a :class:`~hapticfx.formats.device.Device`) and emphasis points (transients).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..signal import MAX_PROFILE_S

MILLISECONDS = 1000  # ticks a second of the analysis' 1 ms grid, where an envelope comes back after a burst
DEFAULT_FREQUENCY = 0.5  # the .haptic spec's default when the frequency envelope is empty
MAX_DURATION_S = MAX_PROFILE_S  # what one file may ask hapticfx to render: a profile (AHAP's continuous events: 30 s)


def grid_size(duration_s: float, rate_hz: float, source: str) -> int:
    """Samples from 0 to ``duration_s`` at ``rate_hz``; a file that asks for more than MAX_DURATION_S is refused."""
    from .base import HapticFileError

    if not duration_s <= MAX_DURATION_S:
        raise HapticFileError(f"lasts {duration_s:.6g} s; hapticfx renders at most {MAX_DURATION_S:g} s of one file",
                              source=source)
    return int(np.floor(duration_s * rate_hz)) + 1


@dataclass(frozen=True)
class Emphasis:
    """A transient: when, how strong (0-1) and how sharp (0-1 frequency)."""

    time_s: float
    amplitude: float
    frequency: float

    def end_s(self, device, frequency: float | None = None) -> float:
        """When the burst stops playing on ``device``, at 0-1 ``frequency`` (default its own: a file may round it)."""
        return self.time_s + device.burst_ms(self.frequency if frequency is None else frequency) / 1000


@dataclass(frozen=True)
class Pattern:
    """Breakpoints: ``amplitude`` (K, 2) of (time s, 0-1); ``frequency`` (M, 2) of (time s, 0-1), may be empty.

    ``peak`` is the largest ``|x|`` of the signal analysed (the limited impact): what a file may not exceed.
    """

    amplitude: np.ndarray
    frequency: np.ndarray
    emphasis: tuple[Emphasis, ...] = ()
    peak: float = 1.0

    @property
    def duration_s(self) -> float:
        return float(self.amplitude[-1, 0])

    def continuous(self, bursts=(), ticks_per_s: int = MILLISECONDS) -> tuple[np.ndarray, np.ndarray]:
        """The amplitude breakpoints ``(t, a)`` a file may carry beside its emphasis: clipped to :attr:`peak`, and 0
        from each burst's start to the first tick (``1 / ticks_per_s``) at or after its end, back on their line one
        tick later.

        ``bursts`` are ``(start s, end s)`` as the reader plays them (the end from what the file says of the burst).
        A burst is played over the continuous signal ducked, not silenced: where the two overlapped, they added up
        past the impact's peak.
        """
        t, a = self.amplitude[:, 0], np.clip(self.amplitude[:, 1], 0.0, min(1.0, self.peak))
        for start, end in bursts:
            t, a = _silent_under(t, a, start, end, ticks_per_s)
        return t, a

    def curves(self, rate_hz: float, source: str = "<pattern>") -> "Curves":
        """The envelopes sampled at ``rate_hz`` from 0 to the last amplitude breakpoint (held before and after)."""
        n = grid_size(self.duration_s, rate_hz, source)
        t = np.arange(n) / rate_hz
        amp = _linear(self.amplitude, t)
        freq = _linear(self.frequency, t) if len(self.frequency) else np.full(n, DEFAULT_FREQUENCY)
        return Curves(rate_hz, amp, freq, self.emphasis)


def written(amplitude: float) -> float:
    """An amplitude as a file holds it: 6 decimals, rounded down, so that no reading exceeds what was analysed."""
    return float(np.floor(amplitude * 1e6) / 1e6)


def first_tick(time_s: float, ticks_per_s: int) -> float:
    """The first tick (``1 / ticks_per_s``) at or after ``time_s``: where the envelope may come back after a burst."""
    return float(np.ceil(time_s * ticks_per_s) / ticks_per_s)


def _silent_under(t: np.ndarray, a: np.ndarray, start: float, end: float,
                  ticks_per_s: int) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoints ``(t, a)`` held at 0 from ``start`` to the first tick at or after ``end`` (a burst's last sample
    as the reader plays it), back on their line one tick later."""
    stop = first_tick(end, ticks_per_s)
    back = min(stop + 1 / ticks_per_s, t[-1])
    resume = [back] if back > stop else []  # none where the burst outlasts the breakpoints
    before, after = t < start, t > back
    return (np.concatenate((t[before], [start, stop], resume, t[after])),
            np.concatenate((a[before], [0.0, 0.0], np.interp(resume, t, a), a[after])))


def _linear(points: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Piecewise-linear through ``points`` (time, value); duplicate times step at that time."""
    return np.interp(t, points[:, 0], points[:, 1])


@dataclass(frozen=True)
class Curves:
    """What the synthesiser plays: amplitude (0-1) and frequency (0-1) per sample, and the transients."""

    rate_hz: float
    amplitude: np.ndarray
    frequency: np.ndarray
    emphasis: tuple[Emphasis, ...] = ()
