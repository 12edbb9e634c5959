"""From head contacts to the helmet actuator's output over the whole shaking.

The simulator submits each contact to :class:`hapticfx.Engine` as it happens
(object, normal velocity, simulation time). The engine renders through the
scene's effects and plays on a memory actuator; afterwards every played
output is placed at its contact time on one timeline at the actuator's rate
and summed. Overlapping impacts can add up beyond a limit that each one
respected, so the mix goes through a fresh safety limiter with the helmet
actuator's effective limits before it is written.
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
    """Sum each played signal at its contact time (``Playback.at``) and limit the sum."""
    n = int(round(duration_s * rate_hz))
    timeline = np.zeros(n)
    for p in sorted(played, key=lambda p: p.at):
        if p.signal.rate_hz != rate_hz:
            raise ValueError(f"{p.object}: played at {p.signal.rate_hz} Hz, the timeline is at {rate_hz} Hz")
        start = int(round(p.at * rate_hz))
        samples = p.signal.samples if p.signal.samples.ndim == 1 else p.signal.samples.sum(axis=0)
        end = min(n, start + samples.shape[-1])
        if start < n:
            timeline[start:end] += samples[: end - start]
    limiter = SafetyLimiter(limits, rate_hz)
    limited = limiter.process(timeline)
    return Mix(Signal(limited, rate_hz), played, limiter.report())
