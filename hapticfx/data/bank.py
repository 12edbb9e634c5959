"""`ProfileBank`: one object's representative 1D profile per recorded velocity."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DatasetError
from ..interfaces import Profile
from ..signal import valid_signal, valid_velocity


@dataclass(frozen=True)
class ProfileBank:
    """Representative profiles of one object, one per velocity, sorted by velocity.

    ``profiles`` has shape ``(n_velocities, n_samples)`` in g at ``rate_hz``.
    """

    object: str
    reducer: str
    rate_hz: float
    velocities: np.ndarray
    profiles: np.ndarray

    def __post_init__(self):
        v = valid_signal(self.velocities, name=f"bank {self.object!r} velocities", ndim=1)
        p = valid_signal(self.profiles, name=f"bank {self.object!r} profiles", ndim=2)
        if p.shape[0] != v.shape[0]:
            raise DatasetError(f"bank {self.object!r}: {v.shape[0]} velocities but {p.shape[0]} profiles")
        if np.any(v < 0) or np.any(np.diff(v) <= 0):
            raise DatasetError(f"bank {self.object!r}: velocities must be non-negative and strictly increasing")
        for name, arr in (("velocities", v), ("profiles", p)):
            arr = np.array(arr, copy=True)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.velocities.shape[0])

    @property
    def n_samples(self) -> int:
        return int(self.profiles.shape[1])

    def __getitem__(self, i: int) -> Profile:
        return Profile(float(self.velocities[i]), self.profiles[i])

    def index_of(self, velocity: float) -> int | None:
        """Index of a recorded velocity equal to ``velocity``, else None."""
        hits = np.flatnonzero(self.velocities == velocity)
        return int(hits[0]) if hits.size else None

    def neighbours(self, velocity: float) -> tuple[Profile, Profile]:
        """The recorded profiles just below and just above ``velocity``.

        ``velocity`` must lie strictly inside the recorded range.
        """
        v = valid_velocity(velocity)
        lo, hi = float(self.velocities[0]), float(self.velocities[-1])
        if not lo < v < hi:
            raise DatasetError(f"velocity {v} m/s is outside the open recorded range ({lo}, {hi}) of {self.object!r}")
        i = int(np.searchsorted(self.velocities, v, side="right"))
        return self[i - 1], self[i]

    def without(self, velocity: float) -> "ProfileBank":
        """The bank with the recorded velocity ``velocity`` left out (cross-validation)."""
        i = self.index_of(velocity)
        if i is None:
            raise DatasetError(f"{velocity} m/s is not recorded for {self.object!r}")
        keep = np.arange(len(self)) != i
        return ProfileBank(self.object, self.reducer, self.rate_hz, self.velocities[keep], self.profiles[keep])
