"""``ensemble``: the recorded neighbours, drawn halfway toward the centre of all their recorded drops.

A representative profile is one drop: its drop-specific detail (a spike where all
three axes happen to go negative, a rebound a little early) is noise to a profile
at another velocity. Every velocity was recorded about ten times, so a robust
centre of those drops - the per-sample trimmed mean - estimates what any drop at
that velocity shares. Between two recorded velocities (``w`` from 0 to 1)::

    blend(w)  = (1 - w) L  + w U            (the representatives: the paper's linear baseline)
    centre(w) = (1 - w) Lc + w Uc           (the neighbours' drop centres)
    profile   = blend(w) + 4 w (1 - w) (centre(w) - blend(w))

At a recorded velocity the recorded representative comes back exactly; halfway
the profile is the blend of the centres. In the core's residual form
(:mod:`hapticfx.interpolators.residual`) the residual is affine in ``w``, so a
velocity table with the two ends of each interval serves it exactly.

``trim`` (the fraction of drops cut at each end, per sample) is learned: ``fit``
picks it from :data:`TRIMS` by leave-one-velocity-out on the training data alone
(mean RMSE against the held-out representative). Datasets written by hapticfx carry
the fitted table (``tables/ensemble-<reducer>.table.npz``,
:mod:`hapticfx.interpolators.fitted`); for others it is fitted when an effect
loads, from the dataset's raw recordings.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..atomic import user_path
from ..errors import DatasetError, SignalError
from ..interfaces import Profile, TrainingData
from ..signal import valid_number
from .residual import scale
from .table import Interval, TableServed, VelocityTable, neighbours

TRIMS = (0.0, 0.1, 0.2, 0.3, 0.4)
FALLBACK_TRIM = 0.4  # a median-like centre, when no velocity has neighbours on both sides to choose by
NAME = "ensemble"


def centres(drops: np.ndarray, trim: float) -> np.ndarray:
    """Per-sample trimmed mean over the drop axis: ``(V, D, N)`` -> ``(V, N)``."""
    d = drops.shape[1]
    k = int(np.floor(trim * d))
    if d - 2 * k < 1:
        k = (d - 1) // 2
    ordered = np.sort(drops, axis=1)
    return ordered[:, k:d - k].mean(axis=1)


def residuals(lower: np.ndarray, upper: np.ndarray, lower_centre: np.ndarray, upper_centre: np.ndarray):
    """The residual at ``w`` = 0 and ``w`` = 1 of one interval (it is affine in between)."""
    s = scale(lower, upper)
    return (lower_centre - lower) / s, (upper_centre - upper) / s


def table_path(dataset_path: Path, reducer: str) -> Path:
    """Where a dataset keeps its fitted ensemble table for ``reducer``."""
    return Path(dataset_path) / "tables" / f"{NAME}-{reducer}.table.npz"


def matching_drops(bank, drops) -> np.ndarray:
    velocities, reduced = drops
    idx = [np.flatnonzero(np.isclose(velocities, v, rtol=0, atol=1e-9)) for v in bank.velocities]
    if any(i.size != 1 for i in idx):
        raise DatasetError(f"object {bank.object!r}: the recorded drops and the bank list different velocities")
    return reduced[[int(i[0]) for i in idx]]


def training_targets(data: TrainingData, obj: str) -> list[int]:
    """Indices of ``obj``'s interior recorded velocities that are training targets of ``data`` (every one when
    ``data.targets`` is None; none for an object left out, whose targets list is empty)."""
    vs = data.banks[obj].velocities
    targets = None if data.targets is None else data.targets.get(obj, vs[1:-1])
    return [i for i in range(1, len(vs) - 1)
            if targets is None or np.isclose(targets, vs[i], rtol=0, atol=1e-9).any()]


TRIM_TARGETS = ("representative", "mean")


def choose_trim(data: TrainingData, *, against: str = "representative") -> tuple[float, dict[float, float]]:
    """The trim with the lowest mean leave-one-velocity-out RMSE on ``data``'s training targets (and every
    trim's score), against each left-out velocity's ``representative`` or the ``mean`` of its drops.

    The representative is the medoid of its drops, so against it a median-like centre wins (``ensemble``'s
    choice); against the mean, which ``bench interpolators`` also scores by, the plain mean usually does.
    """
    if against not in TRIM_TARGETS:
        raise ValueError(f"against must be one of {TRIM_TARGETS}, got {against!r}")
    scores = {t: [] for t in TRIMS}
    for obj, bank in data.banks.items():
        drops = matching_drops(bank, data.drops[obj])
        cs = {t: centres(drops, t) for t in TRIMS}
        reps = bank.profiles
        targets = reps if against == "representative" else drops.mean(axis=1)
        for i in training_targets(data, obj):
            w = (bank.velocities[i] - bank.velocities[i - 1]) / (bank.velocities[i + 1] - bank.velocities[i - 1])
            blend = (1 - w) * reps[i - 1] + w * reps[i + 1]
            for t, c in cs.items():
                centre = (1 - w) * c[i - 1] + w * c[i + 1]
                pred = blend + 4 * w * (1 - w) * (centre - blend)
                scores[t].append(float(np.sqrt(np.mean((pred - targets[i]) ** 2))))
    if not any(scores.values()):
        return FALLBACK_TRIM, {}
    mean = {t: float(np.mean(v)) for t, v in scores.items()}
    return min(TRIMS, key=lambda t: mean[t]), mean


def fit_table(data: TrainingData, *, trim: float | None = None) -> VelocityTable:
    """The ensemble's velocity table for every object of ``data`` (``trim`` chosen when not given)."""
    missing = [obj for obj in data.banks if obj not in data.drops]
    if missing:
        raise DatasetError(f"the ensemble interpolator needs every recorded drop; dataset {data.dataset!r} keeps "
                           f"only representative profiles of {', '.join(missing)} (no raw/ recordings); "
                           "use interpolator: linear")
    scores = None
    if trim is None:
        trim, scores = choose_trim(data)
    intervals = {}
    for obj, bank in data.banks.items():
        c = centres(matching_drops(bank, data.drops[obj]), trim)
        intervals[obj] = [Interval(np.array([0.0, 1.0]), np.stack(residuals(bank.profiles[i], bank.profiles[i + 1],
                                                                             c[i], c[i + 1])))
                          for i in range(len(bank) - 1)]
    return VelocityTable.of(data.banks, intervals, interpolator=NAME, source={"trim": trim}, dataset=data.dataset,
                            tolerance=0.0, fit={"trims": list(TRIMS), "loo_rmse": scores})


class EnsembleInterpolator(TableServed):
    """Neighbours drawn toward the trimmed mean of all their recorded drops (see the module docs).

    Options (effect ``interpolator_options``): ``table`` (a fitted table file; default:
    the dataset's own), ``trim`` (fix the fraction trimmed at each end instead of the
    fitted one; the table is then fitted when the effect loads).
    """

    name = NAME

    def __init__(self, *, table: str | os.PathLike | None = None, trim: float | None = None):
        self.table_file = None if table is None else user_path(table)
        self.trim = None if trim is None else valid_number(trim, name="interpolator_options.trim", minimum=0.0,
                                                           maximum=0.5)
        self.table: VelocityTable | None = None

    fit_table = staticmethod(fit_table)  # what a subclass fits and where a dataset keeps it
    table_path = staticmethod(table_path)

    def fixed(self) -> dict:
        """The options an effect fixes instead of the fitted choice (None: fitted), as ``fit_table`` takes them."""
        return {"trim": self.trim}

    def fit(self, data: TrainingData, **options) -> dict:
        self.table = self.fit_table(data, **self.fixed())
        return {"trim": self.table.meta["source"]["trim"], "loo_rmse": self.table.meta["fit"]["loo_rmse"]}

    def prepare(self, bank, *, dataset=None, base_dir=None) -> None:
        if self.table is None:
            self.table = self._load_or_fit(bank, dataset, base_dir)
        self.table.attach(bank, rebuild="rewrite the dataset's tables with `hapticfx data tables DATASET`")

    def _load_or_fit(self, bank, dataset, base_dir) -> VelocityTable:
        path = self.table_file
        if path is not None and base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        if path is None and dataset is not None:
            path = self.table_path(dataset.path, bank.reducer)
        if path is not None and (self.table_file is not None or path.is_file()):
            table = VelocityTable.load(path)
            if all(v is None or table.meta["source"].get(k) == v for k, v in self.fixed().items()):
                return table
        if dataset is None:
            raise DatasetError(f"the {self.name} interpolator needs its dataset's recorded drops or a fitted table")
        from ..data.training import training_data

        return self.fit_table(training_data(dataset, bank.reducer), **self.fixed())

    def interpolate(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray:
        lo, hi, v = neighbours(lower, upper, velocity)
        found = self.blend(lo, hi, v)
        if found is None:
            raise SignalError(f"{self.name}: no fitted drops for the neighbours at {lo.velocity:g} and {hi.velocity:g} "
                              "m/s; prepare() the interpolator with their bank first")
        return found.of(lo, hi)

    def describe(self) -> dict:
        return {} if self.table is None else {"served_from": self.table.describe(),
                                              "trim": self.table.meta["source"]["trim"]}


__all__ = ["EnsembleInterpolator", "centres", "choose_trim", "fit_table", "matching_drops", "table_path",
           "training_targets", "TRIMS"]
