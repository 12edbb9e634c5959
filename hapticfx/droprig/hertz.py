"""The Hunt-Crossley contact law, shared by the object-helmet and helmet-floor contacts."""

from __future__ import annotations

import numpy as np

G = 9.80665  # standard gravity, m/s^2


def hunt_crossley(delta, rate, *, stiffness: float, damping: float):
    """Hunt-Crossley normal force ``k d^1.5 (1 + alpha d')`` where ``d > 0``; never pulling.

    ``delta`` is the penetration (m), ``rate`` its time derivative (m/s),
    ``stiffness`` k in N/m^1.5, ``damping`` alpha in s/m (Hunt and Crossley 1975).
    """
    d = np.maximum(np.asarray(delta, dtype=np.float64), 0.0)
    f = stiffness * d**1.5 * (1.0 + damping * np.asarray(rate, dtype=np.float64))
    return np.maximum(f, 0.0)
