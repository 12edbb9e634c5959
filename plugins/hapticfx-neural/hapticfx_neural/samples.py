"""Training triples and the network's input encoding (numpy only).

A triple is (lower neighbour, upper neighbour, velocity) -> target profile.

Input encoding, shared by training and inference:

- Profiles are divided by ``scale = max(|lower|, |upper|)`` (the larger peak of the
  two neighbours, per impact). The network therefore sees shapes in [-1, 1]
  whatever the object or unit.
- The network's output is the residual ``r`` of the core's endpoint-consistent form
  (:mod:`hapticfx.interpolators.residual`): the profile is the linear blend of the
  neighbours plus ``4 w (1 - w) * scale * r``, so a neighbour comes back exactly at its
  own velocity and the prediction is continuous there.
- The ``N``-sample profiles are cut into ``steps`` recurrent steps of ``N / steps``
  consecutive samples; each step carries the lower and upper neighbour's chunk
  (two channels, lower first).
- The velocity enters the final dense layer as two features: its relative
  position ``w = (v - v_lower) / (v_upper - v_lower)`` in [0, 1] and its absolute
  value standardised with the training velocities' mean and standard deviation.
  The residual is therefore affine in velocity within a recorded interval, and a
  velocity table needs only each interval's two ends.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hapticfx.errors import DatasetError
from hapticfx.interfaces import Profile
from hapticfx.interpolators.residual import compose, scale as neighbour_scale, weight


@dataclass
class Triples:
    """Stacked triples: ``lower, upper, target (n, N)``; ``v_lo, v_hi, v (n,)``; ``object`` ids."""

    lower: np.ndarray
    upper: np.ndarray
    v_lo: np.ndarray
    v_hi: np.ndarray
    v: np.ndarray
    target: np.ndarray | None
    objects: list[str]

    def __len__(self) -> int:
        return int(self.v.shape[0])

    def subset(self, idx) -> "Triples":
        idx = np.asarray(idx, dtype=int)
        return Triples(self.lower[idx], self.upper[idx], self.v_lo[idx], self.v_hi[idx], self.v[idx],
                       None if self.target is None else self.target[idx], [self.objects[i] for i in idx])


def triples_from_bank(bank, targets) -> Triples:
    """Triples for recorded ``targets`` of ``bank``: each target with its recorded neighbours."""
    rows = []
    for v in targets:
        i = bank.index_of(v)
        if i is None:
            raise DatasetError(f"{v} m/s is not recorded for {bank.object!r}; recorded: "
                               f"{', '.join(f'{x:g}' for x in bank.velocities)}")
        if i == 0 or i == len(bank) - 1:
            raise DatasetError(f"{v} m/s is the lowest or highest recorded velocity of {bank.object!r}: "
                               "it has no neighbour on one side and cannot be a target")
        rows.append((bank[i - 1], bank[i + 1], bank[i]))
    return stack_triples([(lo, hi, float(t.velocity), t.samples) for lo, hi, t in rows], [bank.object] * len(rows))


def stack_triples(rows: list[tuple[Profile, Profile, float, np.ndarray | None]], objects: list[str]) -> Triples:
    lower = np.stack([np.asarray(r[0].samples, np.float64) for r in rows])
    upper = np.stack([np.asarray(r[1].samples, np.float64) for r in rows])
    target = None if rows[0][3] is None else np.stack([np.asarray(r[3], np.float64) for r in rows])
    return Triples(lower, upper, np.array([r[0].velocity for r in rows], float),
                   np.array([r[1].velocity for r in rows], float), np.array([r[2] for r in rows], float),
                   target, list(objects))


def concat(parts: list[Triples]) -> Triples:
    tgt = None if any(p.target is None for p in parts) else np.concatenate([p.target for p in parts])
    return Triples(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("lower", "upper", "v_lo", "v_hi", "v")),
                   tgt, sum((p.objects for p in parts), []))


def encode(t: Triples, *, steps: int, v_mean: float, v_std: float):
    """Network inputs ``x (n, steps, 2, N/steps)``, ``vel (n, 2)`` and the normalised target ``y`` (or None)."""
    n, length = t.lower.shape
    if length % steps:
        raise DatasetError(f"profiles of {length} samples cannot be cut into {steps} equal steps; "
                           "choose model.steps dividing the profile length")
    scale = neighbour_scale(t.lower, t.upper)
    width = length // steps
    pair = np.stack([t.lower, t.upper], axis=1) / scale[:, None, None]           # (n, 2, N)
    x = pair.reshape(n, 2, steps, width).transpose(0, 2, 1, 3)                    # (n, T, 2, S)
    vel = np.stack([weight(t.v_lo, t.v_hi, t.v), (t.v - v_mean) / v_std], axis=1)
    y = None if t.target is None else (t.target / scale[:, None]).reshape(n, steps, width)
    return x.astype(np.float32), vel.astype(np.float32), None if y is None else y.astype(np.float32)


def decode(t: Triples, residual: np.ndarray) -> np.ndarray:
    """Profiles ``(n, N)`` in the bank's units (float64) from the network's residual ``(n, T, S)``."""
    r = np.asarray(residual, dtype=np.float64).reshape(len(t), -1)
    return compose(t.lower, t.upper, weight(t.v_lo, t.v_hi, t.v), r)
