"""The paper's baseline: a velocity-weighted average of the two neighbours, in time."""

from __future__ import annotations

import numpy as np

from ..interfaces import Blend, Interpolator, Profile
from ..signal import valid_signal, valid_velocity


class LinearInterpolator(Interpolator):
    """``(1 - w) * lower + w * upper`` with ``w = (v - v_lower) / (v_upper - v_lower)``."""

    name = "linear"

    def interpolate(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray:
        lo = valid_signal(lower.samples, name="lower profile", ndim=1)
        hi = valid_signal(upper.samples, name="upper profile", ndim=1)
        if lo.shape != hi.shape:
            raise ValueError(f"neighbour profiles differ in length: {lo.shape} and {hi.shape}")
        return self.blend(lower, upper, velocity).of(Profile(lower.velocity, lo), Profile(upper.velocity, hi))

    def blend(self, lower: Profile, upper: Profile, velocity: float) -> Blend:
        v = valid_velocity(velocity)
        span = upper.velocity - lower.velocity
        if span <= 0 or not lower.velocity <= v <= upper.velocity:
            raise ValueError(
                f"velocity {v} must lie within the neighbours [{lower.velocity}, {upper.velocity}]"
            )
        w = (v - lower.velocity) / span
        return Blend(1.0 - w, w)
