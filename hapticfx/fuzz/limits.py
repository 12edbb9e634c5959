"""Random profiles, gains and limit overrides through shaping and the safety limiter, checked the hard way.

For each *override* (an actuator's hard limits, an effect's gain, scale and lowered
limits drawn at random) a stream of random profiles (noise, squares, spikes,
sines; amplitudes from silence to far beyond full scale; random gaps) goes through
the pipeline's stages after the model: :func:`hapticfx.shaping.shape` and one
:class:`~hapticfx.safety.SafetyLimiter` built as a pipeline builds it. The output
is laid out on its own timeline and measured against the *hard* limits: peak,
RMS over every window of the hard window's length, on-time per impact, and
on-time over every duty window. Any excess is a violation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..interfaces import ActuatorSpec, SafetyLimits
from ..safety import SafetyLimiter
from ..shaping import shape
from ..signal import Signal

# Hard limits of the actuators hapticfx ships (the sound-card voice coils, the solenoid) and a plain one.
HARD = (
    ("vibro-transducer", ActuatorSpec(48000.0, 5.0, (20.0, 15000.0), limits=SafetyLimits(peak=1.0, rms=0.7))),
    ("haptuator", ActuatorSpec(48000.0, 5.0, (30.0, 800.0), limits=SafetyLimits(peak=1.0, rms=0.5))),
    ("solenoid", ActuatorSpec(1000.0, 12.0, (0.0, 500.0), waveform=False, limits=SafetyLimits(
        peak=1.0, rms=1.0, max_on_s=0.1, max_duty=0.25, duty_window_s=10.0))),
    ("plain", ActuatorSpec(8000.0, 1.0, (0.0, 4000.0), limits=SafetyLimits(peak=0.8, rms=0.4, rms_window_s=0.02))),
)


@dataclass
class LimitsResult:
    """How many overrides and signals ran, and how many outputs broke a hard limit."""

    overrides: int = 0
    signals: int = 0
    violations: int = 0
    worst: dict | None = None


def _profile(rng: np.random.Generator) -> Signal:
    n = int(rng.integers(1, 800))
    kind = int(rng.integers(0, 4))
    t = np.arange(n) / 1000.0
    if kind == 0:
        x = rng.standard_normal(n)
    elif kind == 1:
        x = np.sign(np.sin(2 * np.pi * rng.uniform(1, 400) * t))
    elif kind == 2:
        x = np.zeros(n)
        x[rng.integers(0, n, size=max(1, n // 50))] = rng.choice([-1.0, 1.0], size=max(1, n // 50))
    else:
        x = np.sin(2 * np.pi * rng.uniform(1, 490) * t)
    amplitude = 10 ** rng.uniform(-4, 3) if rng.random() > 0.05 else 0.0
    return Signal(x * amplitude, 1000.0)


def _override(spec: ActuatorSpec, rng: np.random.Generator) -> SafetyLimits:
    hard = spec.limits
    change = {}
    if rng.random() < 0.5:
        change["peak"] = hard.peak * rng.uniform(0, 1)
    if rng.random() < 0.5:
        change["rms"] = hard.rms * rng.uniform(0, 1)
    if rng.random() < 0.5:
        change["rms_window_s"] = max(1e-4, hard.rms_window_s * rng.uniform(0, 1))
    if rng.random() < 0.3:
        change["max_on_s"] = rng.uniform(0, hard.max_on_s if hard.max_on_s is not None else 1.0)
    if rng.random() < 0.3:
        change["max_duty"] = rng.uniform(0, hard.max_duty if hard.max_duty is not None else 1.0)
    return hard.lowered(**change)


def _max_window_mean_square(x: np.ndarray, win: int, *, chunk: int = 1 << 18) -> float:
    """The largest mean of ``x**2`` over ``win`` consecutive samples, ``chunk`` windows at a time (bounded memory;
    each chunk's running sum starts afresh, so rounding does not build up along a long timeline)."""
    best = 0.0
    for lo in range(0, x.size - win + 1, chunk):
        seg = x[lo:lo + chunk + win - 1]
        sums = np.concatenate([[0.0], np.cumsum(seg * seg)])
        best = max(best, float(np.max(sums[win:] - sums[:-win])))
    return best / win


def excess(out: np.ndarray, spec: ActuatorSpec, threshold: float, gap_s: float) -> dict | None:
    """How far the output timeline goes past the hard limits (None: within them); a pulse is the time above
    ``threshold`` until the output stays under it for ``gap_s``."""
    hard, rate = spec.limits, spec.rate_hz
    found = {}
    magnitude = np.abs(out)
    if out.size and magnitude.max() > hard.peak * (1 + 1e-9):
        found["peak"] = float(magnitude.max())
    on = magnitude > threshold
    del magnitude  # the timeline is about a minute at 48 kHz: few temporaries of its size at once
    win = max(1, int(round(hard.rms_window_s * rate)))
    if out.size >= win:
        worst = float(np.sqrt(_max_window_mean_square(out, win)))
        if worst > hard.rms * (1 + 1e-9):
            found["rms"] = worst
    if hard.max_on_s is not None:
        idx = np.flatnonzero(on)
        ends = np.flatnonzero(np.diff(idx) - 1 >= max(1, round(gap_s * rate)))  # each pulse's last on-sample
        worst_on = float(np.max(np.diff(np.r_[-1, ends, idx.size - 1]))) / rate if idx.size else 0.0
        if worst_on > hard.max_on_s + 1.0 / rate:
            found["on_time_s"] = worst_on
    if hard.max_duty is not None:
        dwin = int(round(hard.duty_window_s * rate))
        c = np.concatenate([[0], np.cumsum(on)])
        if on.size:
            counts = c[dwin:] - c[:-dwin] if on.size >= dwin else np.array([c[-1]])
            duty = float(np.max(counts)) / dwin
            if duty > hard.max_duty + 1.0 / dwin:
                found["duty"] = duty
    return found or None


def check_limits(overrides: int, signals_per_override: int, *, seed: int = 0,
                 progress: Callable[[int], None] | None = None) -> LimitsResult:
    """Run ``overrides`` random overrides with ``signals_per_override`` random profiles each; ``progress(1)``
    after each override."""
    res = LimitsResult()
    for k in range(overrides):
        rng = np.random.default_rng([seed, k])
        name, spec = HARD[int(rng.integers(0, len(HARD)))]
        limits = _override(spec, rng)
        limiter = SafetyLimiter(limits, spec.rate_hz)
        gain, scale = rng.uniform(0, 1), 10 ** rng.uniform(-3, 1)
        blocks, clock = [], 0
        for _ in range(signals_per_override):
            clock += int(rng.integers(0, int(0.3 * spec.rate_hz)))  # a gap of silence, maybe none
            out = limiter.process(shape(_profile(rng), spec, gain=gain, scale=scale).samples,
                                  at_s=clock / spec.rate_hz)
            blocks.append((clock, out))
            clock += out.shape[-1]
            res.signals += 1
        timeline = np.zeros(clock)
        for start, out in blocks:
            timeline[start:start + out.shape[-1]] = out
        del blocks, out
        found = excess(timeline, spec, limiter.on_threshold, limiter.pulse_gap_s)
        res.overrides += 1
        if found:
            res.violations += 1
            res.worst = res.worst or {"actuator": name, "override": k, "limits": repr(limits), **found}
        if progress:
            progress(1)
    return res
