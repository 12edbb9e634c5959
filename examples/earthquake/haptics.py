"""From head contacts to the helmet actuator's output over the whole shaking.

The simulator submits each contact to :class:`hapticfx.Engine` as it happens
(object, normal velocity, simulation time). The engine renders through the
scene's effects and plays on a memory actuator; afterwards every played
output is placed at its contact time on one timeline at the actuator's rate
and summed (one channel per actuator of a scene's ``head``). Overlapping
impacts can add up beyond a limit that each one respected, so the mix goes
through a fresh safety limiter per channel with the helmet actuator's effective
limits before it is written.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hapticfx.effect import check_effect, effective_limits
from hapticfx.engine import Playback
from hapticfx.safety import LimiterReport, SafetyLimiter
from hapticfx.scene import Scene
from hapticfx.signal import Signal


@dataclass(frozen=True)
class Mix:
    """The actuator output over the timeline, what was played, and the final limiter's account."""

    output: Signal
    played: list[Playback]
    limiter: LimiterReport


def output_limits(scene: Scene):
    """The (rate, effective safety limits) of the scene's output; one shared output is expected."""
    outputs = {entry.output for entry in scene.entries.values()}
    if len(outputs) != 1:
        raise ValueError(f"the earthquake demo mixes onto one actuator; the scene has {len(outputs)}: {sorted(outputs)}")
    effect = next(iter(scene.entries.values())).effect
    plan = check_effect(effect)
    spec = plan.actuator_cls(plan.actuator_params, effect.context(device=None)).spec
    return spec.rate_hz, effective_limits(spec.limits, effect)


def mix(played: list[Playback], *, duration_s: float, rate_hz: float, limits) -> Mix:
    """Sum each played signal at its contact time (``Playback.at``) and limit the sum, per channel: a scene
    with a ``head`` of several actuators plays one row per actuator, and gives one channel each."""
    n = int(round(duration_s * rate_hz))
    channels = max((np.atleast_2d(p.signal.samples).shape[0] for p in played), default=1)
    timeline = np.zeros((channels, n))
    for p in sorted(played, key=lambda p: p.at):
        if p.signal.rate_hz != rate_hz:
            raise ValueError(f"{p.object}: played at {p.signal.rate_hz} Hz, the timeline is at {rate_hz} Hz")
        start = int(round(p.at * rate_hz))
        samples = np.atleast_2d(p.signal.samples)
        end = min(n, start + samples.shape[-1])
        if start < n:
            timeline[: samples.shape[0], start:end] += samples[:, : end - start]
    limiters = [SafetyLimiter(limits, rate_hz) for _ in range(channels)]
    limited = np.stack([lim.process(row) for lim, row in zip(limiters, timeline)])
    report = max((lim.report() for lim in limiters), key=lambda r: r.total)
    return Mix(Signal(limited[0] if channels == 1 else limited, rate_hz), played, report)
