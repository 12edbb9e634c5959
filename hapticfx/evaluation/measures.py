"""The floors that recorded drops set for ``hapticfx bench interpolators``: what the recordings score against
each other, and what their mean scores, on the measures of :mod:`hapticfx.processing.likeness` and
:mod:`hapticfx.processing.perceptual`."""

from __future__ import annotations

import numpy as np

from ..processing.likeness import log_spectral_distance, mean_sampling_rmse, peak_error_db, rmse
from ..processing.perceptual import prepare, spqi, st_sim
from ..signal import valid_signal


def leave_one_out_means(drops: np.ndarray) -> np.ndarray:
    """``(D, N)`` -> ``(D, N)``: row ``j`` is the mean of every drop but ``j`` (needs ``D >= 2``)."""
    d = np.asarray(drops, dtype=np.float64)
    return (d.sum(axis=0) - d) / (len(d) - 1)


def floors(drops: np.ndarray, rep: int, *, rate_hz: float = 1000.0) -> dict[str, float]:
    """What the recorded drops at one velocity say is achievable against the representative ``drops[rep]``.

    ``drop_to_drop_*``: each other drop taken as the prediction (mean over them): the
    spread of the recordings themselves. ``mean_of_others_rmse``: the per-sample mean
    of the other drops as the prediction: what a method that knew everything about
    this velocity except the representative's own noise could reach in RMSE (partly
    circular: the representative is the medoid of these same drops). ``mean_sampling_rmse``:
    the floor against the mean of all the drops (:func:`mean_sampling_rmse`).
    ``drop_pairs_lsd_db``: each drop against every other (mean log-spectral distance): what
    a real drop scores on the "LSD vs every drop" measure. ``mean_of_others_lsd_db``: the mean of
    the other drops against each drop (mean log-spectral distance): what a prediction at the drop
    mean, the RMSE floors' ideal, scores on that same measure. Averaging drops whose fine detail
    differs lowers the high-frequency energy, so on some datasets it scores worse than linear's
    blend of two recorded drops: there, the two kinds of criterion pull apart.
    """
    d = valid_signal(drops, name="drops", ndim=2)
    truth = d[rep]
    others = np.delete(d, rep, axis=0)
    if len(others) == 0:
        return {}
    pairs = log_spectral_distance(d[:, None, :], d[None, :, :], rate_hz=rate_hz)
    return {
        "drop_to_drop_rmse": float(np.mean(rmse(others, truth))),
        "drop_to_drop_lsd_db": float(np.mean(log_spectral_distance(others, truth, rate_hz=rate_hz))),
        "drop_to_drop_peak_db": float(np.mean(np.abs(peak_error_db(others, truth)))),
        "mean_of_others_rmse": float(rmse(others.mean(axis=0), truth)),
        "mean_sampling_rmse": mean_sampling_rmse(d),
        "drop_pairs_lsd_db": float(pairs[~np.eye(len(d), dtype=bool)].mean()),
        "mean_of_others_lsd_db": float(np.mean(log_spectral_distance(leave_one_out_means(d), d, rate_hz=rate_hz))),
    }


def drop_pairs(drops, *, rate_hz: float) -> dict[str, float]:
    """What the recordings score against each other: each drop as the prediction of every other drop (mean);
    and ``mean_of_others_*``: the mean of the other drops as the prediction of each drop (the RMSE floors'
    ideal, on these measures)."""
    raw = np.atleast_2d(drops)
    if len(raw) < 2:
        return {}
    d = np.array([prepare(x, rate_hz=rate_hz) for x in raw])
    means = np.array([prepare(m, rate_hz=rate_hz) for m in leave_one_out_means(raw)])
    apart = ~np.eye(len(d), dtype=bool)  # [i, j]: drop i as the prediction of drop j, i != j
    return {"drop_to_drop_stsim": float(np.mean(st_sim(d[:, None], d[None, :])[apart])),
            "drop_to_drop_spqi": float(np.mean(spqi(d[:, None], d[None, :])[apart])),
            "mean_of_others_stsim": float(np.mean(st_sim(means, d))),
            "mean_of_others_spqi": float(np.mean(spqi(means, d)))}
