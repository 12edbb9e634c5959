"""How near the held-out drops' mean a blend of two recorded neighbours could come: measured on a dense drop set.

``bench interpolators`` scores a method against the mean of the held-out velocity's drops and calls the sampling
error of that mean the floor. A method at that floor would know each velocity's population mean exactly; one that
works from the drops of its two recorded neighbours cannot, and how far it stays above the floor depends on the data
(how many drops, how far apart the velocities, how much a profile changes between them). A dense set tells:
each velocity's first ``recorded`` drops play the recorded ones and the rest stand for the population, so for every
interior velocity, left out and predicted from its two neighbours:

- ``linear``: the blend of the neighbours' representatives (the medoids of their recorded drops);
- ``bias``: the morph (:mod:`hapticfx.interpolators.warp`) of the neighbours' **population** means: what is left
  when the neighbours are known exactly, the change between velocities that the morph does not follow;
- ``recorded``: the same morph of the neighbours' plain **recorded** means: that bias and their sampling noise;
- ``method``: an interpolator (the shipped ``ensemble-warp``) fitted to the recorded drops alone, one velocity of
  each object left out per round, as ``bench interpolators`` fits it.

Each is a mean square against the population mean of the left-out velocity, less the sampling noise of the
population means themselves (estimated from their drops, per sample; for a warped morph the noise of its inputs
is taken as that of the plain blend), in units of the floor's square (the sampling variance of a mean of
``recorded`` drops). Each object takes the warp penalty of ``ensemble-warp``'s list with the lowest ``bias``. The
expected RMSE of a prediction against a mean of ``recorded`` drops is then ``sqrt(x + 1)`` floors, and the gap
share ``bench interpolators`` reports follows from it: ``ceiling`` from ``bias`` (what a morph of two neighbours
reaches when it knows them exactly), ``with recorded means`` from ``recorded``, and the method's own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DatasetError
from ..interpolators.ensemble_warp import PENALTIES, morph
from ..processing.representative import medoid

MIN_POPULATION = 10  # drops beyond the recorded ones that stand for the population


@dataclass(frozen=True)
class Fold:
    """One interior velocity of one object; ``linear``, ``bias`` and ``recorded`` in floors squared."""

    object: str
    velocity: float
    w: float
    floor: float    # RMSE of a mean of ``recorded`` drops about the population mean (g)
    linear: float
    bias: dict      # penalty -> value
    recorded: dict  # penalty -> value


def _mse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean((a - b) ** 2))


@dataclass(frozen=True)
class Split:
    """One object's dense drops split: the first ``recorded`` of each velocity and what the rest say."""

    object: str
    velocities: np.ndarray
    sample: np.ndarray   # (V, recorded, N): the recorded drops
    truth: np.ndarray    # (V, N): the population means
    var: np.ndarray      # (V,): the drops' variance about them, mean over samples
    population: int      # drops behind each population mean
    reps: np.ndarray     # (V, N): the representatives, the medoid of each velocity's recorded drops


def split(obj: str, velocities: np.ndarray, drops: np.ndarray, recorded: int) -> Split:
    """``drops`` ``(V, D, N)``: the first ``recorded`` of each velocity's drops are the recorded ones, the other
    ``D - recorded`` (at least :data:`MIN_POPULATION`) the population."""
    d = drops.shape[1]
    if recorded < 2 or d - recorded < MIN_POPULATION:
        raise DatasetError(f"object {obj!r}: {d} drops per velocity; measuring with {recorded} recorded needs at "
                           f"least {recorded + MIN_POPULATION} (and --recorded at least 2): synthesise a dense set, "
                           "e.g. `hapticfx data synth OUT --spec SPEC --drops 60`")
    sample, population = drops[:, :recorded].astype(np.float64), drops[:, recorded:].astype(np.float64)
    return Split(obj, np.asarray(velocities, dtype=np.float64), sample, population.mean(axis=1),
                 population.var(axis=1, ddof=1).mean(axis=-1), population.shape[1],
                 np.stack([s[medoid(s)] for s in sample]))


def _scaled(o: Split, i: int, pred: np.ndarray) -> float:
    """Mean square of ``pred`` against the population mean at ``i``, less that mean's own noise, in floors^2."""
    return (_mse(pred, o.truth[i]) - o.var[i] / o.population) / (o.var[i] / len(o.sample[i]))


def object_folds(o: Split) -> list[Fold]:
    """Every interior velocity of one object, left out and predicted from its two neighbours."""
    truth, var, m = o.truth, o.var, o.population
    means, reps = o.sample.mean(axis=1), o.reps
    out = []
    for i in range(1, len(o.velocities) - 1):
        if var[i] <= 0.0:
            continue  # identical drops: no floor to measure in
        w = float((o.velocities[i] - o.velocities[i - 1]) / (o.velocities[i + 1] - o.velocities[i - 1]))
        inputs = ((1 - w) ** 2 * var[i - 1] + w ** 2 * var[i + 1]) / m / (var[i] / len(o.sample[i]))
        out.append(Fold(o.object, float(o.velocities[i]), w, float(np.sqrt(var[i] / len(o.sample[i]))),
                        _scaled(o, i, (1 - w) * reps[i - 1] + w * reps[i + 1]),
                        {p: _scaled(o, i, morph(truth[i - 1], truth[i + 1], p)(w)) - inputs for p in PENALTIES},
                        {p: _scaled(o, i, morph(means[i - 1], means[i + 1], p)(w)) for p in PENALTIES}))
    return out


def method_values(splits: dict[str, Split], method, *, reducer: str, rate_hz: float,
                  dataset: str = "<dense>", progress=None) -> dict[tuple[str, float], float]:
    """An interpolator fitted to the recorded drops alone, as ``bench interpolators --protocol lovo`` fits it
    (round ``k`` holds out every object's ``k``-th interior velocity): per fold, the same measure as the others.
    ``method``: an interpolator's name, or a row of ``bench interpolators --config``
    (:class:`~hapticfx.evaluation.runner.Method`: its options and fit settings)."""
    from ..data.bank import ProfileBank
    from ..interfaces import TrainingData
    from ..registry import get_registry
    from .folds import lovo_rounds
    from .runner import Method

    m = Method(method, method) if isinstance(method, str) else method

    banks = {o.object: ProfileBank(o.object, reducer, rate_hz, o.velocities, o.reps) for o in splits.values()}
    out = {}
    for k, rnd in enumerate(lovo_rounds(banks)):
        if progress:
            progress(f"{m.row}: round {k + 1}")
        held = rnd.holdout
        train_banks, drops = {}, {}
        for obj, bank in banks.items():
            keep = ~np.isin(bank.velocities, held.get(obj, []))
            for v in held.get(obj, []):
                bank = bank.without(v)
            train_banks[obj] = bank
            drops[obj] = (splits[obj].velocities[keep], splits[obj].sample[keep])
        data = TrainingData(train_banks, reducer, dataset, drops, rnd.targets)
        interp = get_registry().create("interpolator", m.interpolator, **m.options)
        interp.fit(data, **m.fit, label=f"{m.row}, round {k + 1}", progress=progress is not None)
        for bank in train_banks.values():
            interp.prepare(bank)
        for f in rnd.folds:
            o = splits[f.object]
            i = int(np.flatnonzero(o.velocities == f.velocity)[0])
            if o.var[i] > 0.0:
                lo, hi = train_banks[f.object].neighbours(f.velocity)
                out[(f.object, f.velocity)] = _scaled(o, i, interp.interpolate(lo, hi, f.velocity))
    return out


def share(folds: list[Fold], values: list[float]) -> float:
    """The gap share to the floor of the drop-mean measure that ``values`` (floors squared, one per fold) imply,
    pooled over folds as ``bench interpolators`` pools it."""
    f = np.array([x.floor for x in folds])
    rmse = lambda x: np.sqrt(np.maximum(np.asarray(x, dtype=np.float64), 0.0) + 1.0) * f  # noqa: E731
    lin = rmse([x.linear for x in folds]).sum()
    return float((lin - rmse(values).sum()) / (lin - f.sum()))


def summarise(folds: list[Fold], method: dict[tuple[str, float], float] | None = None) -> dict:
    """Per object (and ``all``): folds, the penalty with the lowest bias, the mean of each measure, the shares;
    with ``method`` (:func:`method_values`) its mean and share too."""
    rows = {}
    groups = {o: [x for x in folds if x.object == o] for o in dict.fromkeys(x.object for x in folds)}
    chosen = {o: min(PENALTIES, key=lambda p: np.mean([x.bias[p] for x in fs])) for o, fs in groups.items()}
    for name, fs in [*groups.items(), ("all", folds)]:
        bias = [x.bias[chosen[x.object]] for x in fs]
        rec = [x.recorded[chosen[x.object]] for x in fs]
        rows[name] = {"folds": len(fs), "penalty": chosen.get(name),
                      "linear": float(np.mean([x.linear for x in fs])), "bias": float(np.mean(bias)),
                      "recorded": float(np.mean(rec)), "ceiling": share(fs, bias), "with_recorded": share(fs, rec)}
        if method is not None:
            mv = [method[(x.object, x.velocity)] for x in fs]
            rows[name].update(method=float(np.mean(mv)), method_share=share(fs, mv))
    return rows


__all__ = ["Fold", "MIN_POPULATION", "Split", "method_values", "object_folds", "share", "split", "summarise"]
