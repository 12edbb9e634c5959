"""The texture of an interpolated profile: how much of its recorded neighbours' fine detail it keeps.

A method of the core's residual form (:mod:`hapticfx.interpolators.residual`) draws
the blend of the two recorded representatives toward a centre, ``diff = centre -
blend`` at the target velocity. When the centre is a mean of drops that ring out of
phase, it is duller above about 100 Hz than any recorded drop: nearest the drops'
mean in RMSE, and below linear's blend of two recorded drops on the vibrotactile
field's spectral measures (log-spectral distance, ST-SIM and SPQI against every
drop). Keeping a share ``beta`` of the representatives' content above
:data:`TEXTURE_HZ` trades the one for the other::

    centre' = centre + beta fine(blend - centre),   i.e.   diff' = diff - beta fine(diff)

The neighbours' detail has a phase unrelated to the centre's, so it costs RMSE for
every dB of log-spectral distance it buys. A spectral **fill** buys it more cheaply:
each DFT bin of the textured centre above :data:`TEXTURE_HZ` whose magnitude is below
``g`` times the blend's is raised to it in the centre's own phase, and what that adds
is moved in time to where the blend's fine detail is (:func:`fill`; ``g`` from
:data:`FILLS`, 0: none). Both act on the centre; the profile is drawn toward it
as before (:func:`textured`), so a recorded neighbour still comes back at its own
velocity. A method served from a table fills each interval as at its middle
(``at`` of :func:`textured`).

:func:`choose` picks ``beta`` from :data:`TEXTURES` (and, when asked, ``g`` with it)
on targets left out of the training data (:class:`Target`), as the bench's
generalisation protocol would judge them (module ``hapticfx.evaluation.protocol``,
whose bar :data:`KEEP_SHARE` repeats).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np

from .residual import bump

TEXTURE_HZ = 100.0
TEXTURES = (0.0, 0.2, 0.4, 0.6, 0.8)
FILLS = (0.0, 0.25, 0.5, 0.75)
FILL_FRAME_S = 0.064  # the window of the envelope a fill follows
KEEP_SHARE = 0.6  # of the gap between linear and a floor: the bar of the bench's generalisation protocol
BOOTSTRAP = 500  # resamples of the left-out targets
MEASURES = ("lsd", "stsim", "spqi", "rmse_mean", "rmse_rep")


def fine(x: np.ndarray, rate_hz: float) -> np.ndarray:
    """``x`` ``(..., N)`` above :data:`TEXTURE_HZ`: zero phase, gain ``1 / (1 + (f_c / f)^4)`` (-6 dB at the
    corner, 0 at DC), on a transform twice the profile's length so that its end does not wrap onto its start."""
    n = x.shape[-1]
    f = np.fft.rfftfreq(2 * n, 1.0 / rate_hz)
    gain = np.zeros_like(f)
    gain[1:] = 1.0 / (1.0 + (TEXTURE_HZ / f[1:]) ** 4)
    return np.fft.irfft(np.fft.rfft(x, 2 * n, axis=-1) * gain, 2 * n, axis=-1)[..., :n]


def keep(diff: np.ndarray, beta: float, rate_hz: float) -> np.ndarray:
    """``diff`` (centre - blend) with ``beta`` of the blend's fine detail kept: ``diff - beta fine(diff)``."""
    return diff - beta * fine(diff, rate_hz) if beta else diff


def fill(x: np.ndarray, reference: np.ndarray, g: float, rate_hz: float) -> np.ndarray:
    """``x`` ``(..., N)`` with each DFT bin above :data:`TEXTURE_HZ` whose magnitude is below ``g |reference|``
    raised to it, its phase kept (a silent bin takes the reference's), and what that adds moved in time to where
    the reference's fine detail is (:func:`envelope`), its energy kept; the bins below, and everything at
    ``g = 0``, unchanged. A raised bin spans the whole profile: left where it falls, its energy would reach a
    tail where the drops are silent, which short-time measures (ST-SIM, SPQI) score on its own."""
    if not g:
        return x
    n = x.shape[-1]
    spectrum, ref = np.fft.rfft(x, axis=-1), np.fft.rfft(reference, axis=-1)
    have, want = np.abs(spectrum), g * np.abs(ref)
    low = (np.fft.rfftfreq(n, 1.0 / rate_hz) > TEXTURE_HZ) & (have < want)
    phase = np.where(have > 0, spectrum / np.where(have > 0, have, 1.0), np.exp(1j * np.angle(ref)))
    added = np.fft.irfft(np.where(low, want * phase - spectrum, 0.0), n, axis=-1)
    moved = added * envelope(reference, rate_hz)
    energy = np.sum(added ** 2, axis=-1, keepdims=True)
    kept = np.sum(moved ** 2, axis=-1, keepdims=True)
    return x + moved * np.sqrt(np.divide(energy, kept, out=np.zeros_like(kept), where=kept > 0))


def envelope(x: np.ndarray, rate_hz: float) -> np.ndarray:
    """The RMS of ``x``'s fine detail (:func:`fine`) over :data:`FILL_FRAME_S` (Hann-weighted) at each sample."""
    from scipy.signal import fftconvolve

    frame = max(3, int(round(FILL_FRAME_S * rate_hz)))
    window = np.hanning(frame + 2)[1:-1]
    power = fftconvolve(fine(x, rate_hz) ** 2, np.reshape(window / window.sum(), (1,) * (np.ndim(x) - 1) + (-1,)),
                        mode="same", axes=-1)
    return np.sqrt(np.maximum(power, 0.0))


def filling(blend: np.ndarray, diff: np.ndarray, beta: float, g: float, rate_hz: float) -> np.ndarray:
    """What the fill ``g`` adds to the centre ``blend + keep(diff, beta)``: ``fill(centre, blend, g) - centre``."""
    centre = blend + keep(diff, beta, rate_hz)
    return fill(centre, blend, g, rate_hz) - centre


def textured(diff: np.ndarray, blend: np.ndarray, beta: float, g: float, rate_hz: float, *,
             at: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """``diff`` (centre - blend) as the profile is drawn toward it: ``beta`` of the blend's fine detail kept
    (:func:`keep`), plus the fill ``g`` of the centre so textured (:func:`filling`) where ``at`` = ``(blend, diff)``
    says, by default here. A method served from a table fills each interval as at its middle: the fill is then
    the same all along the interval, and the residual as smooth in velocity as the centre is (a fill computed at
    each velocity bends wherever a bin crosses its bar, and no table of reasonable size follows it)."""
    kept = keep(diff, beta, rate_hz)
    if not g:
        return kept
    return kept + filling(*((blend, diff) if at is None else at), beta, g, rate_hz)


def label(beta: float, g: float) -> str:
    """How :func:`choose`'s scores name a share ``beta`` with fill ``g``: ``"0.4"``, or ``"0.4 fill 0.5"``."""
    return str(float(beta)) if not g else f"{float(beta)} fill {float(g)}"


@dataclass(frozen=True)
class Target:
    """One left-out target: the representatives' ``blend`` at its position ``w``, the method's ``diff`` there
    (centre - blend), and what the target velocity recorded (``drops`` ``(D, N)``, their ``mean``, the bank's
    representative ``rep``); ``at``: the blend and diff where the method computes its fill (:func:`textured`;
    None: at the target); ``lift``: the method's pull toward its centre at ``w`` over the bump
    (:func:`hapticfx.interpolators.residual.lift`)."""

    w: float
    blend: np.ndarray
    diff: np.ndarray
    drops: np.ndarray
    mean: np.ndarray
    rep: np.ndarray
    rate_hz: float
    at: tuple[np.ndarray, np.ndarray] | None = None
    lift: float = 1.0


def choose(targets: Iterable[Target], *, betas=TEXTURES, fills=(0.0,)) -> tuple[tuple[float, float], dict]:
    """The texture ``(beta, g)``, each ``beta`` of ``betas`` with each fill ``g`` of ``fills``, and each pair's mean
    scores (and linear's), named by :func:`label`.

    Each target's profile ``blend + 4 w (1 - w) textured(diff, blend, beta, g)`` is scored against every one of its
    drops by log-spectral distance, ST-SIM and SPQI, beside linear (the blend), and by RMSE against their mean and
    against the representative (:func:`score`). A pair is admissible while it keeps :data:`KEEP_SHARE` of the gap
    between linear and the drop means' sampling floor over every target (the first pair, least ``beta`` and ``g``,
    always is: where the method itself falls short of the bar's share, no RMSE is given up for the spectral
    measures). Of the admissible, the one taken passes the most of the bench's four criteria in expectation over
    :data:`BOOTSTRAP` resamples of the targets (seeded): that share kept against the drop mean, and against the
    representative (floor: the mean of the other drops), log-spectral distance no worse than linear's, ST-SIM and
    SPQI no worse than linear's (sums over the targets, as the bench compares). The least ``beta``, then the least
    ``g``, breaks a tie. A pair that only just passes on these targets is as likely as not to fail on others, which
    the expectation weighs.
    """
    pairs = [(float(b), float(g)) for b in sorted(betas) for g in sorted(fills)]
    folds, floors = score(targets, pairs)
    if not len(floors):
        return pairs[0], {}
    lin = folds["linear"]
    idx = np.random.default_rng(0).integers(0, len(floors), size=(BOOTSTRAP, len(floors)))
    lin_boot, floor_boot = lin[idx].sum(axis=1), floors[idx].sum(axis=1)
    gap = lin[:, 3].sum() - floors[:, 0].sum()
    means = {}
    for b, v in folds.items():
        m = dict(zip(MEASURES, v.mean(axis=0).tolist()))
        m["share"] = float((lin[:, 3].sum() - v[:, 3].sum()) / gap) if gap > 0 else float("nan")
        if b != "linear":
            got = v[idx].sum(axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                shares = (lin_boot[:, 3:5] - got[:, 3:5]) / (lin_boot[:, 3:5] - floor_boot)
            passed = (np.sum(shares >= KEEP_SHARE, axis=1) + (got[:, 0] <= lin_boot[:, 0])
                      + ((got[:, 1] >= lin_boot[:, 1]) & (got[:, 2] >= lin_boot[:, 2])))
            m["expected_criteria"] = float(np.mean(passed))
        means["linear" if b == "linear" else label(*b)] = m
    admissible = [p for p in pairs if p == pairs[0] or means[label(*p)]["share"] >= KEEP_SHARE]
    best = max(round(means[label(*p)]["expected_criteria"], 9) for p in admissible)
    return next(p for p in admissible if round(means[label(*p)]["expected_criteria"], 9) == best), means


def score(targets: Iterable[Target], pairs=tuple((b, 0.0) for b in TEXTURES)) -> tuple[dict, np.ndarray]:
    """Per row (``"linear"``, then each ``(beta, g)`` of ``pairs``) an array ``(targets, 5)`` of :data:`MEASURES`:
    log-spectral distance, ST-SIM and SPQI against every drop (means over them), RMSE against their mean and
    against the representative; and the floors ``(targets, 2)``: the drop mean's sampling error, the other drops' mean against
    the representative. The measures are imported here: a fit needs them, an effect served from its table does
    not."""
    from ..processing.likeness import log_spectral_distance, mean_sampling_rmse, rmse
    from ..processing.perceptual import prepare, spqi, st_sim

    rows: dict = {b: [] for b in ("linear", *pairs)}
    floors = []
    for t in targets:
        refs = np.array([prepare(d, rate_hz=t.rate_hz) for d in t.drops])

        def measured(pred):
            x = prepare(pred, rate_hz=t.rate_hz)
            return (float(np.mean(log_spectral_distance(pred, t.drops, rate_hz=t.rate_hz))),
                    float(np.mean(st_sim(x, refs))), float(np.mean(spqi(x, refs))),
                    float(rmse(pred, t.mean)), float(rmse(pred, t.rep)))

        rows["linear"].append(measured(t.blend))
        for b, g in pairs:
            drawn = bump(t.w) * t.lift * textured(t.diff, t.blend, b, g, t.rate_hz, at=t.at)
            rows[(b, g)].append(measured(t.blend + drawn))
        kept = int(np.argmin(np.sum((t.drops - t.rep) ** 2, axis=1)))  # the drop the bank keeps
        others = np.delete(t.drops, kept, axis=0)
        floors.append((mean_sampling_rmse(t.drops), float(rmse(others.mean(axis=0), t.rep)) if len(others) else np.nan))
    return {b: np.array(v) for b, v in rows.items()}, np.array(floors)


__all__ = ["Target", "choose", "envelope", "fill", "filling", "fine", "keep", "label", "score", "textured", "BOOTSTRAP",
           "FILLS", "FILL_FRAME_S", "KEEP_SHARE", "MEASURES", "TEXTURE_HZ", "TEXTURES"]
