"""Choosing the representative drop per velocity.

The paper picks, by eye, the drop "that has average characteristics" among the
ten (Sect. 4.3). Here the automatic choice is the **medoid**: the drop whose
summed distance to the other drops of the same velocity is smallest, where the
distance between two drops is the Euclidean (Frobenius) norm of the difference
of their preprocessed, trigger-aligned 3-axis windows ``(N, 3)`` in g. A manual
override (velocity -> drop index) replaces the automatic choice.
"""

from __future__ import annotations

import numpy as np

from ..errors import DatasetError
from ..signal import valid_signal

METHOD = "medoid: min sum of Frobenius distances between aligned 3-axis windows (g)"


def distance_matrix(drops) -> np.ndarray:
    """Pairwise Euclidean distances between drops ``(D, ...)`` -> ``(D, D)``."""
    arr = valid_signal(drops, name="drops")
    flat = arr.reshape(arr.shape[0], -1)
    sq = np.sum(flat * flat, axis=1)
    d2 = sq[:, None] + sq[None, :] - 2.0 * flat @ flat.T
    return np.sqrt(np.maximum(d2, 0.0))


def medoid(drops) -> int:
    """Index of the medoid of ``drops`` ``(D, ...)`` (the lowest index on ties)."""
    return int(np.argmin(distance_matrix(drops).sum(axis=1)))


def choose(windows, velocities, overrides: dict[float, int] | None = None, *, label: str = "object") -> tuple[np.ndarray, np.ndarray]:
    """Representative drop per velocity: ``(chosen (V,), automatic (V,))``.

    ``windows`` is ``(V, D, N, 3)``; ``overrides`` maps a recorded velocity
    (matched within 1e-6 m/s) to a drop index.
    """
    w = np.asarray(windows)
    v = np.asarray(velocities, dtype=np.float64)
    auto = np.array([medoid(w[i]) for i in range(w.shape[0])], dtype=np.int64)
    chosen = auto.copy()
    for vel, drop in (overrides or {}).items():
        hits = np.flatnonzero(np.abs(v - float(vel)) <= 1e-6)
        if hits.size == 0:
            raise DatasetError(
                f"{label}: representative override for {vel} m/s, which is not recorded; "
                f"recorded: {', '.join(f'{x:g}' for x in v)}"
            )
        if isinstance(drop, bool) or not isinstance(drop, (int, np.integer)) or not 0 <= drop < w.shape[1]:
            raise DatasetError(f"{label}: representative override for {vel} m/s must be a drop index 0..{w.shape[1] - 1}, got {drop!r}")
        chosen[hits[0]] = int(drop)
    return chosen, auto
