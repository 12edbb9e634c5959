"""The endpoint-consistent form of every learned interpolator: a linear blend plus a bounded residual.

For a velocity ``v`` between the recorded neighbours ``lower`` (at ``v_lo``) and
``upper`` (at ``v_hi``)::

    w       = (v - v_lo) / (v_hi - v_lo)                      in [0, 1]
    s       = max(max|lower|, max|upper|)                     (1 when both are silent)
    profile = (1 - w) * lower + w * upper + 4 w (1 - w) * s * r(v)

``r`` is what a method learns: a dimensionless residual (shapes of order 1). The
bump ``4 w (1 - w)`` is zero at both ends, so the recorded neighbour comes back
exactly at its own velocity whatever ``r`` is, and the profile is continuous in
``v`` wherever ``r`` is. A table of ``r`` on a velocity grid therefore needs no
special blending next to recorded velocities (:mod:`hapticfx.interpolators.table`).
"""

from __future__ import annotations

import numpy as np

_SILENT = 1e-12


def weight(v_lo, v_hi, v):
    """Relative position ``w`` of ``v`` between the neighbours, clipped to [0, 1] (scalars or arrays)."""
    return np.clip((np.asarray(v, dtype=np.float64) - v_lo) / (np.asarray(v_hi, dtype=np.float64) - v_lo), 0.0, 1.0)


def scale(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``s``: the larger peak of the two neighbours, per row (``(..., N)`` -> ``(...)``); 1 where both are silent."""
    s = np.maximum(np.abs(lower).max(axis=-1), np.abs(upper).max(axis=-1))
    return np.where(s > _SILENT, s, 1.0)


def bump(w):
    """``4 w (1 - w)``: zero at both neighbours, one halfway. A float ``w`` (a table's lookup, once per impact) is
    computed in plain floats: no array is made."""
    w = w if isinstance(w, float) else np.asarray(w, dtype=np.float64)
    return 4.0 * w * (1.0 - w)


def valid_pull(p) -> int:
    """``p`` if it is a pull's power, an even integer >= 2; otherwise a ValueError naming it."""
    if not isinstance(p, (int, np.integer)) or p < 2 or p % 2:
        raise ValueError(f"the pull's power must be an even number >= 2, got {p!r}")
    return int(p)


def lift(w, p: int):
    """The pull ``1 - |1 - 2w|^p`` over the bump: ``sum_{k < p/2} (1 - 2w)^(2k)`` for an even ``p`` (1 for ``p = 2``,
    the bump itself). Multiplying a residual by it gives a method the flatter pull toward its centre, one at
    ``w`` = 1/2, zero at both neighbours, and a polynomial in ``w``. A table stores the residual without it and
    weighs its nodes by :func:`pull` instead (:mod:`hapticfx.interpolators.table`): as few nodes as the bump's."""
    u2 = (1.0 - 2.0 * (w if isinstance(w, float) else np.asarray(w, dtype=np.float64))) ** 2
    return sum(u2**k for k in range(valid_pull(p) // 2))


def pull(w, p: int = 2):
    """``1 - |1 - 2w|^p`` (an even ``p``): :func:`bump` times :func:`lift`; the bump itself for ``p = 2``. A float
    ``w`` gives a float."""
    return bump(w) * lift(w, p)


def compose(lower: np.ndarray, upper: np.ndarray, w, residual: np.ndarray) -> np.ndarray:
    """The profile for relative position ``w`` and residual ``r`` (broadcast over leading axes)."""
    w = np.asarray(w, dtype=np.float64)[..., None]
    s = scale(lower, upper)[..., None]
    return (1.0 - w) * lower + w * upper + 4.0 * w * (1.0 - w) * s * residual

