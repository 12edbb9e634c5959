"""The drop-rig simulator: physically based 3-axis helmet recordings.

One drop: an object (mass, size, material) falls onto the helmet dome at a
given velocity with a slightly varying pose (:class:`Variation`; the thin
steel plate varies most, as the paper observed); the contact is integrated
with a Hunt-Crossley law (:mod:`hapticfx.droprig.contact`), rebounds and
secondary impacts included; the helmet answers with its modes
(:mod:`hapticfx.droprig.receiver`); an ADXL335-like sensor behind a 14-bit DAQ
records it at 1 kHz with gravity, clipping and noise (:mod:`hapticfx.droprig.sensor`).

:func:`record_drops` makes ``(V, D, N, 3)`` raw recordings for one object;
:func:`synth_dataset` writes a dataset with banks through
:func:`hapticfx.data.build.build_dataset`. Everything is seeded: the same
arguments give the same arrays.
"""

from __future__ import annotations

import math
import os
import platform
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable

import numpy as np

from ..errors import DatasetError
from ..objects import PAPER_OBJECTS, ObjectInfo
from ..signal import valid_number, valid_signal
from .contact import Block, DropScene, material
from .receiver import Receiver
from .sensor import Accelerometer

if TYPE_CHECKING:
    from .family import Strike

PAPER_VELOCITIES = (2.42, 2.80, 3.13, 3.43, 3.70, 3.96, 4.20, 4.43, 4.65, 4.85, 5.05, 5.24)
BUILTIN_NAME = "helmet-drops"
BUILTIN_SEED = 20230417
BUILTIN_DROPS = 10


@dataclass(frozen=True)
class Variation:
    """Drop-to-drop spread (standard deviations) of pose, contact point and contact law."""

    tilt_deg: float = 1.0
    offset_mm: float = 2.0
    spin_rad_s: float = 0.3
    azimuth_deg: float = 8.0
    velocity_frac: float = 0.004
    stiffness_frac: float = 0.05

    @classmethod
    def for_object(cls, info: ObjectInfo) -> "Variation":
        """Thin plates (thickness under a tenth of their length) tumble: larger spread."""
        dims = [d for d in info.dimensions_mm if d > 0]
        if dims and min(dims) < 0.1 * max(dims):
            return cls(tilt_deg=8.0, offset_mm=12.0, spin_rad_s=4.0, azimuth_deg=35.0,
                       velocity_frac=0.01, stiffness_frac=0.15)
        return cls()


@dataclass(frozen=True)
class Rig:
    """The simulated rig: helmet (the receiver), sensor, grid and integrator settings; ``strike``: an impact
    family's contact (its effect's: :mod:`hapticfx.droprig.family`) instead of a drop onto the helmet, the sensor
    on the side the family's user feels."""

    helmet: Receiver = field(default_factory=Receiver)
    sensor: Accelerometer = field(default_factory=Accelerometer)
    fine_rate_hz: float = 20000.0
    n_samples: int = 700
    pre_s: float = 0.15
    method: str = "LSODA"
    rtol: float = 1e-7
    strike: "Strike | None" = None

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sensor.rate_hz - self.pre_s + 0.005

    def to_dict(self) -> dict:
        d = asdict(self)
        d["helmet"]["modes"] = [asdict(m) for m in self.helmet.modes]
        if self.strike is None:
            del d["strike"]
        return d

    def up(self) -> np.ndarray:
        """Up in the sensor's axes: the sensor reads +1 g along it at rest."""
        if self.strike is not None:
            return self.strike.up(self.helmet)
        return self.helmet.mount_rotation() @ np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Drop:
    """The parameters of one simulated drop."""

    velocity: float
    tilt: float = 0.0
    offset: float = 0.0
    spin: float = 0.0
    azimuth: float = 0.0
    stiffness: float | None = None
    damping: float | None = None


def scene_for(info: ObjectInfo, drop: Drop, helmet: Receiver) -> DropScene:
    """The contact scene of ``drop`` for object ``info`` (material defaults from its table)."""
    mat = material(info.material)
    return DropScene(
        Block.from_dimensions(info.mass_kg, info.dimensions_mm), helmet,
        stiffness=mat.stiffness if drop.stiffness is None else drop.stiffness,
        damping=mat.damping if drop.damping is None else drop.damping,
        velocity=drop.velocity, tilt=drop.tilt, offset=drop.offset, spin=drop.spin,
    )


def simulate_drop(info: ObjectInfo, drop: Drop, *, rig: Rig | None = None, duration_s: float | None = None) -> np.ndarray:
    """Acceleration at the sensor (m/s^2, sensor axes, no gravity), ``(N, 3)`` at ``rig.fine_rate_hz``.

    Time 0 is the release, 0.2 mm above the helmet, or a family's first contact (``rig.strike``: the
    acceleration on the side its user feels). Velocity 0 is no impact: zeros.
    """
    rig = rig or Rig()
    valid_number(drop.velocity, name="velocity", minimum=0.0, maximum=1000.0)
    duration = rig.duration_s if duration_s is None else valid_number(duration_s, name="duration_s", minimum=1e-3)
    n = int(round(duration * rig.fine_rate_hz)) + 1
    if drop.velocity == 0.0:
        return np.zeros((n, 3))
    if rig.strike is not None:
        acc = rig.strike.response(info, drop, rig.helmet, n, rig.fine_rate_hz, rtol=rig.rtol, azimuth=drop.azimuth)
    else:
        scene = scene_for(info, drop, rig.helmet)
        sol = scene.integrate(duration, method=rig.method, rtol=rig.rtol)
        t = np.arange(n) / rig.fine_rate_hz
        states = sol.sol(np.minimum(t, sol.t[-1]))
        acc = rig.helmet.sensor_acceleration(states, rig.fine_rate_hz, azimuth=drop.azimuth)
    if not np.all(np.isfinite(acc)):
        raise DatasetError(f"simulation of {info.id} at {drop.velocity} m/s produced non-finite values")
    return acc


def plan_drops(info: ObjectInfo, velocities, n_drops: int, rng: np.random.Generator,
               variation: Variation | None = None, strike: "Strike | None" = None) -> list[list[Drop]]:
    """Draw the pose of every drop: ``[velocity][drop]``, around a flat landing on the crown with the object's
    material, or around the impact a family's ``strike`` describes."""
    var = variation or Variation.for_object(info)
    mat = material(info.material)
    centre = strike.centre(info, 1.0) if strike is not None else Drop(1.0, stiffness=mat.stiffness, damping=mat.damping)
    plan = []
    for v in velocities:
        row = []
        for _ in range(n_drops):
            z = rng.standard_normal(6)
            row.append(Drop(
                velocity=max(float(v) * (1 + var.velocity_frac * z[0]), 0.0),
                tilt=centre.tilt + math.radians(var.tilt_deg * z[1]),
                offset=centre.offset + var.offset_mm * 1e-3 * z[2],
                spin=var.spin_rad_s * z[3],
                azimuth=math.radians(30.0 + var.azimuth_deg * z[4]),
                stiffness=centre.stiffness * math.exp(var.stiffness_frac * z[5]),
                damping=centre.damping,
            ))
        plan.append(row)
    return plan


def _record_one(args) -> np.ndarray:
    info, drop, rig, seed = args
    rng = np.random.default_rng(seed)
    acc = simulate_drop(info, drop, rig=rig)
    up = rig.up()
    start = rig.pre_s + rng.uniform(0.0, 1.0 / rig.sensor.rate_hz)  # DAQ clock phase
    return rig.sensor.read(acc, rig.fine_rate_hz, start_s=start, n_samples=rig.n_samples, rng=rng, gravity_axis=up)


def resolve_workers(workers: int | None) -> int:
    """Processes to simulate with: ``None`` or ``0`` is every core."""
    return int(workers) if workers else (os.cpu_count() or 1)


def _run_jobs(jobs: list, workers: int | None) -> Iterable[np.ndarray]:
    """``_record_one`` over ``jobs`` in order: serial, or in ``workers`` processes through joblib.

    Each drop carries its own seed, so the arrays do not depend on how many processes ran them.
    The backend is joblib's default (loky processes); a caller's ``joblib.parallel_config(backend=...)``
    (Dask, Ray) takes the same call to a cluster.
    """
    workers = min(resolve_workers(workers), len(jobs))
    if workers <= 1:
        return map(_record_one, jobs)
    from joblib import Parallel, delayed

    return Parallel(n_jobs=workers, return_as="generator")(delayed(_record_one)(j) for j in jobs)


def record_drops(info: ObjectInfo, velocities, n_drops: int, *, seed: int, rig: Rig | None = None,
                 variation: Variation | None = None, workers: int | None = 1,
                 progress: Callable[[str], None] | None = None) -> np.ndarray:
    """Raw recordings ``(V, D, N, 3)`` in g (gravity included) of ``n_drops`` drops per velocity.

    ``workers``: processes (joblib, loky backend); ``None`` or 0 is every core. Same arrays for any value.
    """
    rig = rig or Rig()
    v = valid_signal(velocities, name="velocities", ndim=1)
    if np.any(v <= 0):
        raise DatasetError(f"velocities must be > 0 m/s, got {v.tolist()}")
    if int(n_drops) != n_drops or n_drops < 1:
        raise DatasetError(f"drops must be a positive integer, got {n_drops!r}")
    ss = np.random.SeedSequence([int(seed), *info.id.encode()])
    plan_seed, noise_seed = ss.spawn(2)
    plan = plan_drops(info, v, int(n_drops), np.random.default_rng(plan_seed), variation, rig.strike)
    seeds = noise_seed.generate_state(len(v) * n_drops).reshape(len(v), n_drops)
    jobs = [(info, plan[i][j], rig, int(seeds[i, j])) for i in range(len(v)) for j in range(n_drops)]
    say = progress or (lambda message: None)
    # at once: the first velocity's drops (and the worker processes' start) take seconds
    say(f"{info.id}: simulating {len(jobs)} drops at {len(v)} velocities in "
        f"{min(resolve_workers(workers), len(jobs))} process(es)")
    results = []
    for k, r in enumerate(_run_jobs(jobs, workers)):
        results.append(r)
        if (k + 1) % n_drops == 0:
            say(f"{info.id}: {v[k // n_drops]:.2f} m/s done ({k + 1}/{len(jobs)} drops)")
    return np.asarray(results, dtype=np.float32).reshape(len(v), n_drops, rig.n_samples, 3)


def synth_dataset(out: Path, objects: Iterable[ObjectInfo], velocities=PAPER_VELOCITIES, *,
                  drops: int = BUILTIN_DROPS, seed: int = BUILTIN_SEED, name: str | None = None,
                  rig: Rig | None = None, variation: Variation | None = None, workers: int | None = 1,
                  overwrite: bool = False, progress: Callable[[str], None] | None = None,
                  command: str | None = None) -> Path:
    """Simulate every object's drops and write a dataset (raw + banks for both reducers) to ``out``.

    ``velocities``: one list for every object, or a mapping object id -> its own list. ``variation``: the
    drop-to-drop spread of every object (default: :meth:`Variation.for_object`).
    """
    from ..data.build import ObjectRecordings, build_dataset, check_velocities
    from ..data.dataset import check_output

    rig = rig or Rig()
    objects = list(objects)
    if not objects:
        raise DatasetError("no objects to simulate")
    # what would fail in writing the dataset fails before minutes of simulation, not after
    per_object = {o.id: check_velocities(velocities[o.id] if isinstance(velocities, dict) else velocities,
                                         f"object {o.id!r}", minimum=2) for o in objects}
    check_output(Path(out), overwrite=overwrite)
    started = time.perf_counter()
    recordings = [
        ObjectRecordings(info, per_object[info.id], record_drops(info, per_object[info.id], drops, seed=seed, rig=rig,
                                                                 variation=variation, workers=workers,
                                                                 progress=progress))
        for info in objects
    ]
    from .. import __version__ as hapticfx_version

    provenance = {
        "generator": "hapticfx.droprig.synth (simulated drop rig; not a measurement)",
        "command": command or "hapticfx.droprig.synth.synth_dataset (Python API)",
        "seed": int(seed),
        "drops": int(drops),
        "velocities_mps": ({k: v.tolist() for k, v in per_object.items()} if isinstance(velocities, dict)
                           else next(iter(per_object.values())).tolist()),
        "hapticfx_version": hapticfx_version,
        "numpy": np.__version__,
        "python": platform.python_version(),
        "rig": rig.to_dict(),
        "materials": {o.id: asdict(material(o.material)) for o in objects},
        "variation": {o.id: asdict(variation or Variation.for_object(o)) for o in objects},
        "simulation_s": round(time.perf_counter() - started, 2),
    }
    return build_dataset(
        Path(out), recordings, name=name or Path(out).name, rate_hz=rig.sensor.rate_hz,
        sensor=rig.sensor.to_dict(), provenance=provenance, overwrite=overwrite, progress=progress,
    )


def builtin_path() -> Path:
    """Where ``builtin:helmet-drops`` lives inside the package."""
    from ..data.dataset import BUILTIN_DIR

    return BUILTIN_DIR / BUILTIN_NAME


def synth_builtin(*, workers: int | None = None, progress: Callable[[str], None] | None = None,
                  out: Path | None = None) -> Path:
    """Regenerate ``builtin:helmet-drops``: the paper's 4 objects x 12 velocities x 10 drops."""
    path = synth_dataset(
        out or builtin_path(), PAPER_OBJECTS.values(), PAPER_VELOCITIES, drops=BUILTIN_DROPS,
        seed=BUILTIN_SEED, name=BUILTIN_NAME, workers=workers, overwrite=True, progress=progress,
        command="hapticfx data synth --builtin",
    )
    return path

