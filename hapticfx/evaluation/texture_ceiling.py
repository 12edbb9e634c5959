"""What the spectral criteria leave to a method whose centre is right: the ceiling of the texture trade.

``bench interpolators`` asks a method to come near the held-out velocity's drop mean (RMSE) and to be no worse
than linear's blend of two recorded drops on measures against every drop (log-spectral distance, ST-SIM, SPQI). A
mean of drops that ring out of phase is duller above about 100 Hz than any drop, so the two kinds of criterion pull
apart; methods of the core's residual form trade one for the other with a texture share ``beta``
(:mod:`hapticfx.interpolators.texture`). This measures the best that trade allows, from the drops themselves.

For every interior velocity of every object (each left out as in ``lovo``, from its two recorded neighbours), the
centre is the mean of that velocity's other drops, scored against the drop left out (so no drop is scored against
a mean that holds it), with ``beta`` of the neighbours' blend's fine detail kept, as
:func:`~hapticfx.interpolators.texture.keep` keeps it: ``centre + beta fine(blend - centre)``. The spectral
measures are means over the drops, beside linear's blend of the two representatives against the same drops.

On RMSE a right centre errs by the floors of ``bench interpolators``: the drop mean's sampling error against the
mean, the other drops' mean against the representative. The texture adds ``beta rms(fine(blend - mean))`` to
either in quadrature (its detail comes from the neighbours, independent of the target's drops); the gap shares
follow as the bench computes them, from means over the folds. Point estimates, no intervals.

With ``fills``, each share is also scored with a spectral fill on top
(:func:`~hapticfx.interpolators.texture.fill`): the textured centre's phase kept, every bin above 100 Hz whose
magnitude is below ``g`` times the blend's raised to it. Added in phase with the centre, it buys more log-spectral
distance per unit of RMSE than the neighbours' detail, whose phase is unrelated to the centre's; its cost is the
RMS of what it and the texture add to each left-out centre. ``ensemble-warp`` fills the same way when its ``fill``
option asks it to, each interval as at its middle.

Beside them, what a recorded drop of the velocity scores on the same spectral measures, each drop taken as the
prediction of every other (:func:`~hapticfx.evaluation.measures.floors` and
:func:`~hapticfx.evaluation.measures.drop_pairs`, as ``bench interpolators`` reports them): where a real recording
is worse than linear, "no worse than linear" asks more of a method than the recordings themselves give.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import DatasetError
from ..interpolators.residual import weight
from ..interpolators.texture import KEEP_SHARE, TEXTURES, fine, keep, textured
from ..processing.likeness import log_spectral_distance, mean_sampling_rmse, rmse
from ..processing.perceptual import prepare, spqi, st_sim
from .measures import drop_pairs, floors, leave_one_out_means

SPECTRAL = ("lsd", "stsim", "spqi")


@dataclass(frozen=True)
class Fold:
    """One left-out velocity: linear's and each texture share's spectral means over the drops, the RMSE floors, and
    what the texture costs."""

    object: str
    velocity: float
    linear: dict     # lsd, stsim, spqi, rmse_mean, rmse_rep
    floors: dict     # rmse_mean, rmse_rep
    textured: dict   # beta -> {lsd, stsim, spqi, cost}
    recorded: dict   # lsd, stsim, spqi: each drop against every other
    filled: dict = field(default_factory=dict)  # (beta, g) -> {lsd, stsim, spqi, cost}, for each fill g > 0


def _spectral(preds: np.ndarray, drops: np.ndarray, refs: np.ndarray, rate_hz: float) -> dict:
    """Mean LSD, ST-SIM and SPQI of ``preds[j]`` against ``drops[j]`` (one prediction ``(N,)``: against every drop)."""
    one = preds.ndim == 1
    got = prepare(preds, rate_hz=rate_hz) if one else np.array([prepare(p, rate_hz=rate_hz) for p in preds])
    preds = np.broadcast_to(preds, drops.shape)
    return {"lsd": float(np.mean(log_spectral_distance(preds, drops, rate_hz=rate_hz))),
            "stsim": float(np.mean(st_sim(got, refs))), "spqi": float(np.mean(spqi(got, refs)))}


def fold(obj: str, velocity: float, blend: np.ndarray, drops: np.ndarray, rep: int, *, rate_hz: float,
         betas=TEXTURES, fills=()) -> Fold:
    """The fold at ``velocity``: ``blend`` of its neighbours' representatives, its ``drops`` ``(D, N)`` (D >= 2) and
    the index of its representative among them; with each fill ``g`` of ``fills`` on each share too."""
    d = np.asarray(drops, dtype=np.float64)
    blend = np.asarray(blend, dtype=np.float64)
    refs = np.array([prepare(x, rate_hz=rate_hz) for x in d])
    mean, centres = d.mean(axis=0), leave_one_out_means(d)  # centres[rep]: the other drops' mean
    linear = {**_spectral(blend, d, refs, rate_hz), "rmse_mean": float(rmse(blend, mean)),
              "rmse_rep": float(rmse(blend, d[rep]))}
    detail = float(np.sqrt(np.mean(fine(blend - mean, rate_hz) ** 2)))
    kept_share, filled = {}, {}
    for b in betas:
        kept = blend + keep(centres - blend, b, rate_hz)
        kept_share[b] = {**_spectral(kept, d, refs, rate_hz), "cost": b * detail}
        for g in (g for g in fills if g > 0):
            pred = blend + textured(centres - blend, blend, b, g, rate_hz)
            filled[(b, g)] = {**_spectral(pred, d, refs, rate_hz),
                              "cost": float(np.sqrt(np.mean((pred - centres) ** 2)))}
    pairs = drop_pairs(d, rate_hz=rate_hz)
    recorded = {"lsd": floors(d, rep, rate_hz=rate_hz)["drop_pairs_lsd_db"], "stsim": pairs["drop_to_drop_stsim"],
                "spqi": pairs["drop_to_drop_spqi"]}
    return Fold(obj, float(velocity), linear, {"rmse_mean": mean_sampling_rmse(d),
                                               "rmse_rep": float(rmse(centres[rep], d[rep]))}, kept_share, recorded,
                filled)


def dataset_folds(dataset, reducer: str, *, fills=(), progress=None) -> list[Fold]:
    """Every fold of ``dataset``: each object's interior velocities, with the bank's representatives as the
    neighbours and the dataset's own choice of representative among the target's drops."""
    from ..data.training import recorded_drops

    folds = []
    for obj in dataset.objects:
        found = recorded_drops(dataset, obj, reducer)
        if found is None:
            raise DatasetError(f"dataset {dataset.name!r} keeps no drops of {obj!r} (no raw/ recordings)")
        velocities, drops = found
        if drops.shape[1] < 2:
            raise DatasetError(f"dataset {dataset.name!r}, object {obj!r}: 1 drop per velocity; the texture's "
                               "ceiling needs at least 2 (each is scored against the mean of the others)")
        bank, chosen = dataset.bank(obj, reducer), dataset.representatives(obj)["chosen"]
        for j in range(1, len(velocities) - 1):
            v = float(velocities[j])
            w = float(weight(velocities[j - 1], velocities[j + 1], v))
            lo, hi = (bank.profiles[bank.index_of(float(velocities[k]))] for k in (j - 1, j + 1))
            folds.append(fold(obj, v, (1.0 - w) * lo + w * hi, drops[j], int(chosen[j]), rate_hz=dataset.rate_hz,
                              fills=fills))
        if progress is not None:
            progress(f"{dataset.name}: {obj}: {len(velocities) - 2} velocities scored")
    if not folds:
        raise DatasetError(f"dataset {dataset.name!r}: no object has a velocity with recorded neighbours on both sides")
    return folds


def summarise(folds: list[Fold], betas=TEXTURES, fills=()) -> list[dict]:
    """Per texture share, then per share and fill ``g > 0`` of ``fills``: the gap shares of a right centre so
    textured, its spectral measures as ratios to linear's (means over the folds), and how many of the bench's four
    criteria it meets."""
    lin = {k: np.mean([f.linear[k] for f in folds]) for k in (*SPECTRAL, "rmse_mean", "rmse_rep")}
    floor = {k: np.array([f.floors[k] for f in folds]) for k in ("rmse_mean", "rmse_rep")}
    gap = {k: lin[k] - floor[k].mean() for k in floor}  # none: NaN, as the bench reports it
    rows = []
    for b, g in [(b, 0.0) for b in betas] + [(b, g) for g in fills if g > 0 for b in betas]:
        got = [f.filled[(b, g)] if g else f.textured[b] for f in folds]
        cost = np.array([x["cost"] for x in got])
        share = {k: float((lin[k] - np.mean(np.hypot(floor[k], cost))) / gap[k]) if gap[k] > 0 else float("nan")
                 for k in floor}
        ratio = {k: float(np.mean([x[k] for x in got]) / lin[k]) for k in SPECTRAL}
        met = int(share["rmse_mean"] >= KEEP_SHARE) + int(share["rmse_rep"] >= KEEP_SHARE) + sum(_spectral_met(ratio))
        rows.append({"texture": b, "fill": g, "share_mean": share["rmse_mean"], "share_rep": share["rmse_rep"],
                     **ratio, "criteria": met})
    return rows


def _spectral_met(ratio: dict) -> tuple[bool, bool]:
    """The bench's two spectral criteria on ratios to linear: LSD no worse, and ST-SIM and SPQI no worse."""
    return ratio["lsd"] <= 1.0, ratio["stsim"] >= 1.0 and ratio["spqi"] >= 1.0


def recorded(folds: list[Fold]) -> dict:
    """A recorded drop's spectral measures (each drop against every other), as ratios to linear's (means over the
    folds), and whether it would meet the bench's LSD and perceptual criteria."""
    ratio = {k: float(np.mean([f.recorded[k] for f in folds]) / np.mean([f.linear[k] for f in folds]))
             for k in SPECTRAL}
    lsd_met, perceptual_met = _spectral_met(ratio)
    return {**ratio, "lsd_met": lsd_met, "perceptual_met": perceptual_met}


__all__ = ["Fold", "dataset_folds", "fold", "recorded", "summarise"]
