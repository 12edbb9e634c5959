"""Physics models served from velocity tables: the ODE is solved to build a table, never per impact.

A model whose profile depends only on the impact velocity (for one effect and
object) is tabulated once over ``(0, v_max]``:

* knots on a geometric grid from ``v_max * FLOOR`` to ``v_max`` (ratio 2; an
  interval that will not converge is split), where the profile is computed
  directly;
* between two knots, the same residual form and Chebyshev-Lobatto tables as the
  learned interpolators (:func:`hapticfx.interpolators.table.tabulate_interval`):
  the profile is the polynomial through the directly computed profiles at the
  nodes, their number doubled until it agrees with direct computation within
  ``tolerance`` of the larger neighbour's peak; an interval still short of it at
  degree ``MAX_DEGREE`` is split, and one still short after ``MAX_SPLITS``
  splits (a profile that is not smooth in velocity there: contacts chattering)
  becomes a straight line between its close knots, recorded in the table's
  ``unconverged`` list: a model serves velocities there by direct computation
  (:meth:`PhysicsTable.served_at`), not from the line;
* below the first knot, the first knot's profile scaled by ``(v / v_floor)^a``, ``a`` the power law of the
  first two knots' peaks (within :data:`BELOW_POWER`): continuous, silence at 0, the shape there the first
  knot's (a contact's peak grows faster than the velocity: as ``v^1.2`` for a Hertzian one).

The table records a ``source`` (a SHA-256 of everything the profiles depend
on: the model's parameters, the object, the receiver, :data:`PHYSICS_VERSION`);
a table built for other parameters is never served. Tables live in a user cache
folder (:func:`hapticfx.caches.cache_root`) under ``physics/<sha>.npz``, or ship next to an effect in
``tables/<sha>.npz``.

An impact costs a blend of two knots' profiles and one small matrix product at
the profile's rate; the pipeline then shapes it.
"""

from __future__ import annotations

import hashlib
import json
import math
import threading
import time
from pathlib import Path
from typing import Callable

import numpy as np

from ..caches import cache_root
from ..errors import CheckpointError, SignalError
from ..interpolators.residual import bump, scale
from ..interpolators.table import Interval, VelocityTable, tabulate_interval

# Bump when the physics changes what a profile is for the same parameters (a table built before is then stale).
PHYSICS_VERSION = 1
FORMAT_NAME = "physics"
FLOOR = 1.0 / 256  # the lowest knot, relative to v_max
RATIO = 2.0  # between neighbouring knots
TOLERANCE = 4e-7  # of the larger neighbour's peak, at the probes
MAX_DEGREE = 64  # per interval before it is split
MAX_SPLITS = 3
BELOW_POWER = (1.0, 2.0)  # the bounds of the power law below the first knot

ProfileFn = Callable[[float], np.ndarray]  # velocity (m/s) -> profile (N,)


def source_digest(spec: dict) -> str:
    """SHA-256 of what a table's profiles depend on (a JSON-able mapping), with :data:`PHYSICS_VERSION`."""
    text = json.dumps({"physics_version": PHYSICS_VERSION, **spec}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def cache_dir() -> Path:
    """Where built physics tables are kept for the next run."""
    return cache_root() / FORMAT_NAME


def knots(v_max: float) -> np.ndarray:
    """The starting velocity grid: ``v_max * RATIO**-k`` down to ``v_max * FLOOR``, increasing."""
    n = math.ceil(math.log(1.0 / FLOOR) / math.log(RATIO))
    return v_max * RATIO ** -np.arange(n, -1, -1, dtype=np.float64)


class PhysicsTable:
    """One object's profiles over ``(0, v_max]``: knot profiles plus a :class:`VelocityTable` between them."""

    def __init__(self, table: VelocityTable):
        self.table = table
        self.object = next(iter(table.meta["objects"]))
        self.rate_hz = float(table.meta["rate_hz"])
        self.velocities = np.asarray(table.arrays["knot_velocities"], dtype=np.float64)
        self.profiles = np.asarray(table.arrays["knot_profiles"], dtype=np.float64)
        ivs = table.intervals[self.object]
        if self.profiles.shape != (len(self.velocities), table.meta["n_samples"]) or len(ivs) != len(self.velocities) - 1:
            raise CheckpointError(f"{table.where}: knots do not match the table's intervals")
        self._intervals = ivs
        self.unconverged = [(float(a), float(b)) for a, b in table.meta.get("unconverged", [])]
        self._scales = [float(scale(self.profiles[i], self.profiles[i + 1])) for i in range(len(ivs))]
        self.v_max = float(self.velocities[-1])
        peaks = np.max(np.abs(self.profiles[:2]), axis=1)
        power = math.log(peaks[1] / peaks[0]) / math.log(self.velocities[1] / self.velocities[0]) \
            if np.all(peaks > 0) else 1.0
        self._below = float(np.clip(power, *BELOW_POWER))

    @property
    def source(self) -> str:
        return self.table.meta["source"]["physics_sha256"]

    def served_at(self, velocity: float) -> bool:
        """Whether the table holds the profile at ``velocity`` within its tolerance: not inside an interval that
        did not converge (there it is a straight line between two knots, off by up to a tenth of the peak)."""
        return not any(a < velocity < b for a, b in self.unconverged)

    def profile(self, velocity: float) -> np.ndarray:
        """The profile at ``velocity``: the knots' blend plus the interval's polynomial (one small matrix product)."""
        v = float(velocity)
        if not 0.0 <= v <= self.v_max:
            raise SignalError(f"velocity {v:g} m/s is past this effect's range (0 to {self.v_max:g} m/s); raise "
                              "model.max_velocity_mps to render it")
        knot = self.velocities
        if v <= knot[0]:
            return (v / knot[0]) ** self._below * self.profiles[0]
        i = min(int(np.searchsorted(knot, v, side="right")) - 1, len(knot) - 2)
        w = (v - knot[i]) / (knot[i + 1] - knot[i])
        out = (1.0 - w) * self.profiles[i] + w * self.profiles[i + 1]
        k = float(bump(w)) * self._scales[i]
        if k:
            out += k * self._intervals[i].at(w)
        return out

    def describe(self) -> dict:
        meta = self.table.meta
        return {"table": self.table.where, "knots": len(self.velocities), "nodes": self.table.n_nodes,
                "v_max": self.v_max, "tolerance": meta["tolerance"], "build_s": meta.get("build_s"),
                **({"integrated_directly_mps": self.unconverged} if self.unconverged else {})}


def build(obj: str, profile: ProfileFn, *, v_max: float, rate_hz: float, source: str, reducer: str,
          tolerance: float = TOLERANCE, progress: Callable[[str], None] | None = None) -> PhysicsTable:
    """Tabulate ``profile`` (direct computation) for object ``obj`` over ``(0, v_max]``."""
    say = progress or (lambda message: None)
    started = time.perf_counter()
    direct: dict[float, np.ndarray] = {}

    def at(v: float) -> np.ndarray:
        if v not in direct:
            direct[v] = np.asarray(profile(float(v)), dtype=np.float64)
        return direct[v]

    def residual(lower, upper, v_lo, v_hi, v, _obj):
        out = np.empty_like(lower)
        for row, (lo_p, hi_p, a, b, x) in enumerate(zip(lower, upper, v_lo, v_hi, v)):
            w = (x - a) / (b - a)
            k = float(bump(w)) * float(scale(lo_p, hi_p))
            out[row] = np.nan if k == 0.0 else (at(x) - (1.0 - w) * lo_p - w * hi_p) / k
        return out

    from ..interfaces import Profile

    unconverged: list[list[float]] = []

    def span(a: float, b: float, depth: int) -> list[tuple[float, Interval]]:
        try:
            iv = tabulate_interval(Profile(a, at(a)), Profile(b, at(b)), residual, tolerance, obj=obj,
                                   max_degree=MAX_DEGREE, probes=2)
            # float32 keeps ~6e-8 of the residual's scale: within the tolerance, half the file
            return [(a, Interval(iv.w, iv.residual.astype(np.float32).astype(np.float64)))]
        except CheckpointError:
            if depth >= MAX_SPLITS:
                # not smooth in velocity here (contacts chattering on and off): a straight line between two close
                # knots keeps the table continuous and bounded; the range is recorded, `bench physics` measures it
                unconverged.append([a, b])
                return [(a, Interval(np.array([0.0, 1.0]), np.zeros((2, at(a).shape[-1]))))]
            mid = math.sqrt(a * b)
            return span(a, mid, depth + 1) + span(mid, b, depth + 1)

    grid = knots(v_max)
    pieces: list[tuple[float, Interval]] = []
    for a, b in zip(grid[:-1], grid[1:]):
        pieces += span(float(a), float(b), 0)
        say(f"{obj}: {b:.4g} m/s of {v_max:g} ({len(direct)} direct profiles)")
    velocities = np.array([a for a, _ in pieces] + [float(grid[-1])])
    profiles = np.stack([at(v) for v in velocities])
    meta = {"format": "hapticfx-interpolator-table", "version": 1, "interpolator": FORMAT_NAME,
            "source": {"physics_sha256": source}, "dataset": "physics", "reducer": reducer,
            "n_samples": int(profiles.shape[1]), "tolerance": tolerance, "rate_hz": float(rate_hz),
            "objects": {obj: {"velocities": velocities.tolist()}},
            "direct_profiles": len(direct), "unconverged": unconverged,
            "build_s": round(time.perf_counter() - started, 3)}
    table = VelocityTable(meta, {obj: [iv for _, iv in pieces]}, arrays={"knot_velocities": velocities, "knot_profiles": profiles})
    return PhysicsTable(table)


_LOCK = threading.Lock()


def load_or_build(obj: str, profile: ProfileFn, *, v_max: float, rate_hz: float, spec: dict, reducer: str,
                  shipped: Path | None = None, progress: Callable[[str], None] | None = None) -> PhysicsTable:
    """The table for ``spec``: shipped (``shipped/<sha>.npz``), else cached, else built now and cached."""
    # the object's id beside its description (spec["object"]: mass, size, material), which it must not replace
    digest = source_digest({**spec, "object_id": obj, "v_max": v_max, "rate_hz": rate_hz, "reducer": reducer})
    name = f"{digest}.npz"
    with _LOCK:
        for folder in (shipped, cache_dir()):
            path = None if folder is None else Path(folder) / name
            if path is not None and path.is_file():
                table = PhysicsTable(VelocityTable.load(path))
                table.table.check_source(FORMAT_NAME, {"physics_sha256": digest},
                                         rebuild=f"delete {path} to rebuild it")
                return table
        table = build(obj, profile, v_max=v_max, rate_hz=rate_hz, source=digest, reducer=reducer, progress=progress)
        try:
            table.table.save(cache_dir() / name, residual_dtype=np.float32)  # rounded so when built
        except OSError:  # a read-only home still renders; the table is rebuilt next time
            pass
        return table


__all__ = ["PhysicsTable", "build", "load_or_build", "source_digest", "cache_dir", "knots", "PHYSICS_VERSION"]
