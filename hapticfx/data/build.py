"""Building a dataset directory from 3-axis drop recordings.

:func:`build_dataset` preprocesses every drop (:mod:`hapticfx.processing.preprocess`),
picks a representative drop per velocity (:mod:`hapticfx.processing.representative`,
honouring manual overrides), and writes the raw recordings, one bank per reducer
and the tables of the interpolators fitted to every drop (``ensemble`` and
``ensemble-warp``, :mod:`hapticfx.interpolators.fitted`) per reducer atomically with
:class:`~hapticfx.data.dataset.DatasetWriter`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from ..errors import DatasetError, HapticfxError
from ..interfaces import TrainingData
from ..interpolators.fitted import save_tables
from ..objects import ObjectInfo
from ..processing import representative
from ..processing.preprocess import Preprocessing, preprocess
from ..processing.reducers import reduce_checked
from ..signal import valid_number, valid_signal
from .bank import ProfileBank
from .dataset import DatasetWriter


@dataclass
class ObjectRecordings:
    """All drops of one object: ``accel_g`` is ``(V, D, N_raw, 3)`` raw g (gravity included).

    ``velocities_mps`` is ``(V,)``; ``representative_overrides`` maps a recorded
    velocity to the drop index to use instead of the automatic choice.
    """

    info: ObjectInfo
    velocities_mps: np.ndarray
    accel_g: np.ndarray
    representative_overrides: dict[float, int] = field(default_factory=dict)

    def __post_init__(self):
        label = f"object {self.info.id!r}"
        v = check_velocities(self.velocities_mps, label)
        try:
            a = valid_signal(self.accel_g, name=f"{label} accel_g", ndim=4)
        except HapticfxError as exc:
            raise DatasetError(str(exc)) from None
        if a.shape[0] != v.shape[0] or a.shape[-1] != 3:
            raise DatasetError(f"{label}: accel_g must have shape ({v.shape[0]}, drops, samples, 3), got {a.shape}")
        order = np.argsort(v, kind="stable")
        self.velocities_mps = v[order]
        self.accel_g = a[order]


def check_velocities(velocities, label: str, *, minimum: int = 1) -> np.ndarray:
    """The recorded velocities of one object (``label`` names it) as an array: finite, > 0 m/s, each once,
    and at least ``minimum`` of them (a dataset needs two, which its models interpolate between; the
    recordings of one drop height have one)."""
    try:
        v = valid_signal(velocities, name=f"{label} velocities_mps", ndim=1)
    except HapticfxError as exc:
        raise DatasetError(str(exc)) from None
    if np.any(v <= 0):
        raise DatasetError(f"{label}: velocities must be > 0 m/s, got {v.tolist()}")
    if len(np.unique(v)) < len(v):
        raise DatasetError(f"{label}: velocity recorded twice in {v.tolist()}; put all drops of a velocity together")
    if len(v) < minimum:
        raise DatasetError(f"{label}: needs drops at {minimum} or more velocities to interpolate between, "
                           f"got {v.tolist()}")
    return v


def _check_reducers(reducers) -> list[tuple[str, object]]:
    from ..registry import get_registry

    registry = get_registry()
    return [(name, registry.create("reducer", name)) for name in reducers]


def build_dataset(
    out: Path,
    recordings: Iterable[ObjectRecordings],
    *,
    name: str,
    rate_hz: float,
    sensor: dict,
    provenance: dict,
    reducers=("max-min", "dft321"),
    overwrite: bool = False,
    progress: Callable[[str], None] | None = None,
    preprocessing: Preprocessing | None = None,
) -> Path:
    """Write a dataset to ``out`` and return its path; nothing is left behind on error.

    ``rate_hz`` is the rate of the raw recordings; banks are at
    ``preprocessing.rate_hz`` (1 kHz) with ``preprocessing.n_samples`` (500) samples.
    """
    rate = valid_number(rate_hz, name="rate_hz", minimum=1.0)
    params = preprocessing or Preprocessing()
    if params.cutoff_hz >= min(rate, params.rate_hz) / 2:
        raise DatasetError(f"high-pass cutoff {params.cutoff_hz} Hz is not below the Nyquist frequency of {rate} Hz")
    reducer_objs = _check_reducers(reducers)
    say = progress or (lambda message: None)
    out = Path(out)
    with DatasetWriter(
        out, name=name, rate_hz=params.rate_hz, n_samples=params.n_samples, overwrite=overwrite,
        raw_rate_hz=rate, sensor=dict(sensor), provenance=dict(provenance),
        preprocessing=params.to_dict(), representative_method=representative.METHOD,
    ) as writer:
        seen: set[str] = set()
        fits: dict[str, list] = {rname: [] for rname, _ in reducer_objs}
        for rec in recordings:
            oid = rec.info.id
            if oid in seen:
                raise DatasetError(f"object {oid!r} given twice")
            seen.add(oid)
            check_velocities(rec.velocities_mps, f"object {oid!r}", minimum=2)
            say(f"{oid}: preprocessing {rec.accel_g.shape[0]} velocities x {rec.accel_g.shape[1]} drops")
            # Preprocess what is stored (float32), so that the banks, the fitted tables and
            # Dataset.windows() all see the same numbers.
            stored = np.asarray(rec.accel_g, np.float32)
            windows = preprocess(stored.astype(np.float64), rate, params=params)
            chosen, auto = representative.choose(
                windows, rec.velocities_mps, rec.representative_overrides, label=f"object {oid!r}"
            )
            writer.add_object(
                rec.info,
                n_drops=int(rec.accel_g.shape[1]),
                velocities_mps=rec.velocities_mps.tolist(),
                representative={
                    "chosen": chosen.tolist(),
                    "automatic": auto.tolist(),
                    "overrides": [
                        {"velocity_mps": float(v), "drop": int(d)}
                        for v, d in sorted(rec.representative_overrides.items())
                    ],
                },
            )
            writer.write_raw(oid, rec.velocities_mps, stored)
            picked = windows[np.arange(windows.shape[0]), chosen]
            for rname, reducer in reducer_objs:
                say(f"{oid}: bank {rname}")
                where = dict(source=str(out), label=f"object {oid!r}")
                profiles = reduce_checked(reducer, rname, picked, **where)
                writer.write_bank(rname, oid, rec.velocities_mps, profiles, chosen)
                bank = ProfileBank(oid, rname, params.rate_hz, rec.velocities_mps, profiles)
                fits[rname].append((bank, (rec.velocities_mps, reduce_checked(reducer, rname, windows, **where))))
        if not seen:
            raise DatasetError(f"{out}: no recordings given")
        for rname, items in fits.items():
            data = TrainingData({b.object: b for b, _ in items}, rname, name, {b.object: d for b, d in items})
            save_tables(data, writer.tmp, progress=say)
    say(f"wrote {out}")
    return out


# A velocity a user types is matched to a recorded one within half the last of the four decimals that
# messages print (velocities from a drop height, sqrt(2 g h), have more digits than anyone types).
VELOCITY_DECIMALS = 4


def velocity_text(v: float) -> str:
    """A recorded velocity as messages print it: 4 decimals, trailing zeros dropped."""
    return f"{v:.{VELOCITY_DECIMALS}f}".rstrip("0").rstrip(".")


def recorded_index(object_id: str, velocities: np.ndarray, velocity_mps: float) -> int:
    """The index of the recorded velocity ``velocity_mps`` names (the nearest, within half the last printed
    decimal); ``DatasetError`` listing the recorded ones when none is that close."""
    near = np.abs(np.asarray(velocities, dtype=np.float64) - velocity_mps)
    if not near.size or not near.min() <= 0.5 * 10.0 ** -VELOCITY_DECIMALS + 1e-12:  # NaN is near nothing
        raise DatasetError(f"{object_id} has no drops at {velocity_text(velocity_mps)} m/s; recorded: "
                           + ", ".join(velocity_text(v) for v in velocities))
    return int(np.argmin(near))


def set_representative(path: Path, object_id: str, velocity_mps: float, drop: int | None,
                       *, progress: Callable[[str], None] | None = None) -> Path:
    """Set (``drop``) or clear (``None``) the manual representative of one velocity and rebuild the banks.

    The override is stored in the dataset's metadata; the raw recordings, sensor,
    provenance, preprocessing and reducers are kept. A built-in dataset is part of the installed package
    and is refused: pick in a copy of it.
    """
    from .dataset import BUILTIN_DIR, BUILTIN_PREFIX, open_dataset

    ds = open_dataset(path)
    if ds.path.resolve().is_relative_to(BUILTIN_DIR):
        raise DatasetError(f"{BUILTIN_PREFIX}{ds.path.name} is installed with hapticfx and is not rewritten; "
                           f"copy it first (cp -r {ds.path} my-drops) and pick in the copy")
    if object_id not in ds.objects:
        raise DatasetError(f"dataset {ds.name!r} has no object {object_id!r}; it has: {', '.join(ds.objects)}")
    recordings = []
    for oid in ds.objects:
        velocities, accel = ds.raw(oid)
        overrides = {float(o["velocity_mps"]): int(o["drop"])
                     for o in ds.meta["objects"][oid].get("representative", {}).get("overrides", [])}
        if oid == object_id:
            v = float(velocities[recorded_index(object_id, velocities, velocity_mps)])
            overrides = {k: d for k, d in overrides.items() if abs(k - v) > 1e-6}
            if drop is not None:
                overrides[v] = int(drop)
        recordings.append(ObjectRecordings(ds.object_info(oid), velocities, accel, overrides))
    meta = ds.meta
    return build_dataset(
        ds.path, recordings, name=ds.name, rate_hz=ds.raw_rate_hz, sensor=meta.get("sensor", {}),
        provenance=meta.get("provenance", {}), reducers=tuple(ds.reducers()), overwrite=True, progress=progress,
        preprocessing=Preprocessing.from_dict(meta.get("preprocessing", {})),
    )
