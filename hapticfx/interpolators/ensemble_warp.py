"""``ensemble-warp``: the ``ensemble`` with its neighbours' drop centres registered in time before they blend.

``ensemble`` draws the two recorded neighbours toward the straight blend of their
drop centres (:mod:`hapticfx.interpolators.ensemble`). When an event of the profile
moves with velocity - an object bouncing on the helmet comes back later the faster
it fell - that blend shows the event twice at half height. Here the centres are
aligned by dynamic time warping and morphed (:mod:`hapticfx.interpolators.warp`)::

    blend(w)  = (1 - w) L + w U                        (the representatives)
    centre(w) = morph(Lc, Uc, w)                       (time and value moved a fraction w)
    profile   = blend(w) + 4 w (1 - w) (centre(w) - blend(w))

The recorded representative comes back at its own velocity. Two choices are
learned from the training data alone, leaving one training velocity out at a
time: ``trim`` exactly as ``ensemble`` chooses it (against the representative),
then the warp ``penalty`` from :data:`PENALTIES` (``inf``: no warp, the
``ensemble`` itself) **for each object**, against the mean of the left-out
velocity's drops. An object's events move with velocity by its own law (a heavy
object bounces late, a light one not at all; a helmet's ringing stays where it
is, and a warp that pairs its cycles one period apart is worse than none), so
one penalty for a whole dataset is wrong for some of its objects; and the mean
of a velocity's drops is a far less noisy yardstick than its one representative
drop. An object with fewer than :data:`MIN_FOLDS` velocities to leave out (and
an object the training data gives no targets of: a new object) takes the
penalty that scores best over every object's folds.

Served from a velocity table like ``ensemble``. The morph is not a polynomial in
``w``, so each interval's residual is tabulated on Chebyshev nodes until it misses
the method by at most :data:`TOLERANCE` of the neighbours' larger peak; with no
warp two nodes suffice.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DatasetError, SignalError
from ..interfaces import Profile, TrainingData
from . import ensemble
from .ensemble import EnsembleInterpolator, centres, matching_drops
from .residual import compose, scale
from .table import VelocityTable, build_table, neighbours
from .warp import Morph, displacement, warp_path

NAME = "ensemble-warp"
PENALTIES = (0.01, 0.03, float("inf"))
TOLERANCE = 1e-3  # of the neighbours' larger peak: -60 dB


def _morph(lo_c: np.ndarray, hi_c: np.ndarray, penalty: float) -> Morph:
    """The morph from one drop centre to the next (``penalty`` inf: no warp, the plain blend)."""
    d = displacement(warp_path(lo_c, hi_c, penalty=penalty), len(lo_c)) if np.isfinite(penalty) \
        else np.zeros_like(lo_c)
    return Morph(lo_c, hi_c, d)


MIN_FOLDS = 3  # left-out velocities an object needs to choose its own penalty


def choose_penalties(data: TrainingData, trim: float) -> tuple[dict[str, float], float, dict[str, dict[float, float]]]:
    """The warp penalty of every object, the pooled penalty, and every object's scores.

    Each training target of an object is left out in turn and predicted from its neighbours' centres (trimmed
    by ``trim``); the score is the mean RMSE against the mean of the left-out velocity's drops. An object takes
    its own best penalty when it has at least :data:`MIN_FOLDS` such folds, otherwise the pooled one: the best
    mean over every object's folds (``inf``, no warp, when no object has a fold).
    """
    scores: dict[str, dict[float, list[float]]] = {}
    for obj, bank in data.banks.items():
        drops = matching_drops(bank, data.drops[obj])
        c, truth = centres(drops, trim), drops.mean(axis=1)
        reps, vs = bank.profiles, bank.velocities
        targets = None if data.targets is None else data.targets.get(obj, vs[1:-1])
        own = scores[obj] = {p: [] for p in PENALTIES}
        for i in range(1, len(bank) - 1):
            if targets is not None and not np.isclose(targets, vs[i], rtol=0, atol=1e-9).any():
                continue  # not a training target (for example an object left out)
            w = (vs[i] - vs[i - 1]) / (vs[i + 1] - vs[i - 1])
            blend = (1 - w) * reps[i - 1] + w * reps[i + 1]
            for p in PENALTIES:
                pred = blend + 4 * w * (1 - w) * (_morph(c[i - 1], c[i + 1], p)(w) - blend)
                own[p].append(float(np.sqrt(np.mean((pred - truth[i]) ** 2))))
    pooled_scores = {p: [x for own in scores.values() for x in own[p]] for p in PENALTIES}
    pooled = min(PENALTIES, key=lambda p: np.mean(pooled_scores[p])) if pooled_scores[PENALTIES[0]] else float("inf")
    chosen = {obj: min(PENALTIES, key=lambda p: np.mean(own[p])) if len(own[PENALTIES[0]]) >= MIN_FOLDS else pooled
              for obj, own in scores.items()}
    means = {obj: {p: float(np.mean(v)) for p, v in own.items()} for obj, own in scores.items() if own[PENALTIES[0]]}
    return chosen, pooled, means


class Fit:
    """What the method learned from ``data``: ``trim``, every object's ``penalties`` and drop centres; the morph
    of each recorded interval is made on first use."""

    def __init__(self, data: TrainingData, *, trim: float | None = None):
        missing = [obj for obj in data.banks if obj not in data.drops]
        if missing:
            raise DatasetError(f"the {NAME} interpolator needs every recorded drop; dataset {data.dataset!r} keeps "
                               f"only representative profiles of {', '.join(missing)} (no raw/ recordings); "
                               "use interpolator: linear")
        self.data = data
        self.trim_scores = self.penalty_scores = None
        self.trim = trim
        if trim is None:
            self.trim, self.trim_scores = ensemble.choose_trim(data)
        self.penalties, self.pooled_penalty, self.penalty_scores = choose_penalties(data, self.trim)
        self.centres = {obj: centres(matching_drops(bank, data.drops[obj]), self.trim)
                        for obj, bank in data.banks.items()}
        self._morphs: dict[tuple[str, int], Morph] = {}
        self._index = {(obj, float(v)): i for obj, bank in data.banks.items() for i, v in enumerate(bank.velocities)}

    def morph(self, obj: str, i: int) -> Morph:
        """The morph from the centre at recorded velocity ``i`` of ``obj`` to the one at ``i + 1``."""
        key = (obj, i)
        if key not in self._morphs:
            self._morphs[key] = _morph(self.centres[obj][i], self.centres[obj][i + 1], self.penalties[obj])
        return self._morphs[key]

    def residual(self, obj: str, v_lo: float, lower: np.ndarray, upper: np.ndarray, w: float) -> np.ndarray:
        """``r`` of :mod:`hapticfx.interpolators.residual` at ``w`` between ``lower`` (at ``v_lo``) and ``upper``."""
        centre = self.morph(obj, self._index[(obj, float(v_lo))])(w)
        return (centre - (1 - w) * lower - w * upper) / scale(lower, upper)

    def find(self, lower, upper) -> str | None:
        """The object whose recorded neighbours ``lower`` and ``upper`` are (None: not fitted)."""
        for obj, bank in self.data.banks.items():
            i = self._index.get((obj, float(lower.velocity)))
            if i is not None and i + 1 < len(bank) and bank.velocities[i + 1] == upper.velocity \
                    and np.array_equal(bank.profiles[i], lower.samples) \
                    and np.array_equal(bank.profiles[i + 1], upper.samples):
                return obj
        return None

    def summary(self) -> dict:
        def name(p):
            return None if not np.isfinite(p) else p

        return {"trim": self.trim, "penalty": {obj: name(p) for obj, p in self.penalties.items()},
                "pooled_penalty": name(self.pooled_penalty),
                "warped_objects": sum(bool(np.isfinite(p)) for p in self.penalties.values()),
                "loo_rmse": self.trim_scores,
                "penalty_loo_rmse": {obj: {("inf" if not np.isfinite(p) else str(p)): x for p, x in own.items()}
                                     for obj, own in self.penalty_scores.items()}}


def table_path(dataset_path: Path, reducer: str) -> Path:
    """Where a dataset keeps its fitted ensemble-warp table for ``reducer``."""
    return Path(dataset_path) / "tables" / f"{NAME}-{reducer}.table.npz"


def tabulate(fit: Fit, *, progress=None) -> VelocityTable:
    """``fit`` as a velocity table (every object and interval of its data)."""
    def residual(lower, upper, v_lo, v_hi, v, obj):
        return np.stack([fit.residual(obj, v_lo[k], lower[k], upper[k], (v[k] - v_lo[k]) / (v_hi[k] - v_lo[k]))
                         for k in range(len(v))])

    table = build_table(fit.data.banks.values(), residual, interpolator=NAME,
                        source={"trim": fit.trim, "penalty": fit.summary()["penalty"]}, dataset=fit.data.dataset,
                        tolerance=TOLERANCE, progress=progress)
    table.meta["fit"] = fit.summary()
    return table


def fit_table(data: TrainingData, *, trim: float | None = None) -> VelocityTable:
    """The ensemble-warp's velocity table for every object of ``data`` (``trim`` and the penalty chosen when
    ``trim`` is not given)."""
    return tabulate(Fit(data, trim=trim))


class EnsembleWarpInterpolator(EnsembleInterpolator):
    """The ensemble with its neighbours' drop centres aligned in time before they blend (see the module docs).
    Options as ``ensemble``'s: ``table``, ``trim``.

    After :meth:`fit` (an evaluation) it answers directly from what it fitted; an effect serves it from its
    table (the dataset's ``tables/ensemble-warp-<reducer>.table.npz``, or tabulated when the effect loads).
    """

    name = NAME
    fitted: Fit | None = None

    fit_table = staticmethod(fit_table)
    table_path = staticmethod(table_path)

    def fit(self, data: TrainingData, **options) -> dict:
        self.fitted, self.table = Fit(data, trim=self.trim), None
        return {k: v for k, v in self.fitted.summary().items() if not isinstance(v, dict)}

    def prepare(self, bank, *, dataset=None, base_dir=None) -> None:
        if self.fitted is None:
            super().prepare(bank, dataset=dataset, base_dir=base_dir)

    def interpolate(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray:
        if self.fitted is None:
            return super().interpolate(lower, upper, velocity)
        lo, hi, v = neighbours(lower, upper, velocity)
        obj = self.fitted.find(lo, hi)
        if obj is None:
            raise SignalError(f"{self.name}: no fitted drops for the neighbours at {lo.velocity:g} and "
                              f"{hi.velocity:g} m/s")
        w = (v - lo.velocity) / (hi.velocity - lo.velocity)
        return compose(lo.samples, hi.samples, w, self.fitted.residual(obj, lo.velocity, lo.samples, hi.samples, w))

    def describe(self) -> dict:
        if self.fitted is not None:
            return {"fitted": self.fitted.summary()}
        return {} if self.table is None else {**super().describe(), "penalty": self.table.meta["source"]["penalty"]}


__all__ = ["EnsembleWarpInterpolator", "Fit", "choose_penalties", "fit_table", "tabulate", "table_path", "MIN_FOLDS",
           "PENALTIES", "TOLERANCE"]
