"""``ensemble-warp``: the ``ensemble`` with its neighbours' drop centres registered in time before they blend.

``ensemble`` draws the two recorded neighbours toward the straight blend of their
drop centres (:mod:`hapticfx.interpolators.ensemble`). When an event of the profile
moves with velocity - an object bouncing on the helmet comes back later the faster
it fell - that blend shows the event twice at half height. Here the centres are
aligned by dynamic time warping and morphed (:mod:`hapticfx.interpolators.warp`)::

    blend(w)  = (1 - w) L + w U                        (the representatives)
    centre(w) = morph(Lc, Uc, w)                       (time and value moved a fraction w)
    profile   = blend(w) + 4 w (1 - w) (centre(w) - blend(w))     (the pull below: 1 - |1 - 2w|^p)

The recorded representative comes back at its own velocity. Three choices are
learned from the training data alone, leaving one training velocity out at a
time and scoring against the mean of the left-out velocity's drops: ``trim``
from ``ensemble``'s list (``ensemble`` chooses it against the representative,
the medoid of those drops, which favours a median-like centre; against their
mean the plain mean usually wins, and it is the better estimate of what the
neighbours share), then the warp ``penalty`` from :data:`PENALTIES` (``inf``: no
warp, the ``ensemble`` itself) **for each object**. An object's events move
with velocity by its own law (a heavy object bounces late, a light one not at
all; a helmet's ringing stays where it is, and a warp that pairs its cycles one
period apart is worse than none), so one penalty for a whole dataset is wrong
for some of its objects; and the mean of a velocity's drops is a far less noisy
yardstick than its one representative drop. An object with fewer than
:data:`MIN_FOLDS` velocities to leave out (and an object the training data gives
no targets of: a new object) takes the penalty that scores best over every
object's folds.

Then, chosen the same way for each object: whether its centres are **shrunk**
first (:func:`shrunk_centres`). With few drops a centre is noisy, and the
profile changes smoothly enough with velocity that its neighbours predict much
of it; each interior centre is drawn toward its neighbours' morph by the share
of their disagreement that is its own sampling noise (the jackknife over its
drops), an empirical-Bayes smoother across velocity that pools the drops of
four recorded velocities into each interval instead of two. Where the profile
changes faster than the noise (many drops, sparse velocities) it is left out.

Last, for each object the warp left out (one whose events stay put as velocity
changes): whether its centres are instead **smoothed** across every recorded
velocity (:func:`smoothed_centres`, a Whittaker smoother) and how strongly, from
:data:`SMOOTHING`. Shrinking pools the drops of four velocities into an interval;
a smooth curve through every centre pools them all, at the cost of bending where
the profile changes fast, which the same leave-one-out choice weighs. It is not
offered where a warp was chosen: a smoother in raw time blurs events that move.

Then, for the whole dataset: how strongly the profile is **pulled** toward the
centre, ``1 - |1 - 2w|^p`` with ``p`` from :data:`PULLS` (2: the bump above),
chosen by the same left-out RMSE (:func:`choose_pull`). The bump pulls fully only
halfway between two recorded velocities; where they are irregularly spaced a
velocity often lies far from halfway, and the profile keeps much of the blend of
two single drops whose noise the centre averages out. The residual is the bump's
times :func:`~hapticfx.interpolators.residual.lift`, a polynomial in ``w``: the
recorded neighbour still comes back at its own velocity.

Last, for the whole dataset: how much **texture** the profile keeps, the share
``beta`` of the representatives' content above 100 Hz that the centre does not
replace (:mod:`hapticfx.interpolators.texture`)::

    centre'(w) = centre(w) + beta fine(blend(w) - centre(w))

A mean of drops that ring out of phase is duller above about 100 Hz than any
recorded drop, and on the vibrotactile field's spectral measures it can score below
linear's blend of two recorded drops, while it is nearest their mean in RMSE.
``beta`` trades the one for the other, chosen on the same left-out training
velocities (:func:`texture_targets`). With it, and by the same choice, a **fill**:
the textured centre's bins above 100 Hz quieter than ``g`` times the blend's are
raised to it in the centre's own phase, and what that adds is moved in time to
where the blend's fine detail is, ``g`` from
:data:`~hapticfx.interpolators.texture.FILLS` (0: none). The neighbours' detail
has a phase unrelated to the centre's, so it costs RMSE for each dB of
log-spectral distance it buys; the fill buys it more cheaply. Each interval is
filled as at its middle (``at`` of :func:`~hapticfx.interpolators.texture.textured`),
so that its table stays as small as without a fill. The option ``fill`` fixes
``g`` instead (0: the form before the fill was offered).

Served from a velocity table like ``ensemble``. The morph is not a polynomial in
``w``, so each interval's residual is tabulated on Chebyshev nodes until it misses
the method by at most :data:`TOLERANCE` of the neighbours' larger peak; with no
warp two nodes suffice (a table weighs its nodes by the pull, so the pull adds none).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import DatasetError, SignalError
from ..interfaces import Profile, TrainingData
from ..signal import valid_number
from . import ensemble
from .ensemble import EnsembleInterpolator, centres, matching_drops, training_targets
from .residual import compose, lift, pull, scale
from .table import VelocityTable, build_table, neighbours
from .texture import FILLS, TEXTURES, Target, choose as choose_texture, filling, keep as keep_texture

if TYPE_CHECKING:
    from .warp import Morph

NAME = "ensemble-warp"
CHOOSE = "choose"  # the fill option's value that asks for it to be chosen
PENALTIES = (0.01, 0.03, float("inf"))
PULLS = (2, 4, 6)  # the pull toward the centres, 1 - |1 - 2w|^p: 2 is the bump 4 w (1 - w)
TOLERANCE = 1e-3  # of the neighbours' larger peak: -60 dB


def morph(lo_c: np.ndarray, hi_c: np.ndarray, penalty: float, paths: dict | None = None) -> Morph:
    """The morph from one drop centre to the next (``penalty`` inf: no warp, the plain blend).

    ``paths``: displacements already found, by centres and penalty. Choosing a penalty and whether to shrink
    aligns the same pair of centres again and again, and the alignment is most of a morph's cost.
    :mod:`hapticfx.interpolators.warp` (scipy's resampling and splines) is imported here, when a fit needs it:
    an effect served from its table never loads it.
    """
    from .warp import Morph, displacement, warp_path

    if not np.isfinite(penalty):
        return Morph(lo_c, hi_c, np.zeros_like(lo_c))
    key = (lo_c.tobytes(), hi_c.tobytes(), penalty)
    d = None if paths is None else paths.get(key)
    if d is None:
        d = displacement(warp_path(lo_c, hi_c, penalty=penalty), len(lo_c))
        if paths is not None:
            paths[key] = d
    return Morph(lo_c, hi_c, d)


MIN_FOLDS = 3  # left-out velocities an object needs to make its own choices
SHRINK = (False, True)


def jackknife_noise(drops: np.ndarray, trim: float) -> np.ndarray:
    """The sampling variance of each velocity's centre, mean over samples: ``(V, D, N)`` -> ``(V,)`` (g^2).

    The jackknife over drops: ``(D - 1) / D sum_j (c_(j) - mean c_(j))^2``, ``c_(j)`` the centre without drop
    ``j``; for a plain mean (``trim`` 0) it is the sample variance over ``D``. Zero with one drop.
    """
    v, d, _ = drops.shape
    if d < 2:
        return np.zeros(v)
    loo = np.stack([centres(np.delete(drops, j, axis=1), trim) for j in range(d)])
    return (d - 1) / d * np.sum((loo - loo.mean(axis=0)) ** 2, axis=0).mean(axis=-1)


def shrunk_centres(velocities: np.ndarray, c: np.ndarray, noise: np.ndarray, penalty: float,
                   paths: dict | None = None) -> np.ndarray:
    """Every interior centre drawn toward what its two neighbours predict of it (empirical Bayes).

    ``e_k = c_k - morph(c_{k-1}, c_{k+1})(w_k)``; ``c_k - a_k e_k`` with ``a_k = min(1, noise_k / mean_j |e_j|^2)``:
    the share of what the neighbours miss that is ``c_k``'s own sampling noise (the rest is theirs, and how the
    profile changes between them). The ends keep their centres.
    """
    out = np.array(c, dtype=np.float64, copy=True)
    inner = range(1, len(velocities) - 1)
    errors = [c[k] - morph(c[k - 1], c[k + 1], penalty, paths)(
        float((velocities[k] - velocities[k - 1]) / (velocities[k + 1] - velocities[k - 1]))) for k in inner]
    mse = float(np.mean([np.mean(e ** 2) for e in errors])) if errors else 0.0
    if mse > 0.0:
        for k, e in zip(inner, errors):
            out[k] = c[k] - min(1.0, noise[k] / mse) * e
    return out


SMOOTHING = (1e-5, 1e-4, 1e-3, 1e-2)  # Whittaker penalties, velocity scaled to [0, 1]


def smoothed_centres(velocities: np.ndarray, c: np.ndarray, strength: float) -> np.ndarray:
    """The centres ``c`` ``(V, N)`` replaced by the smooth curve through them across velocity (Whittaker).

    Per sample, ``x`` minimises ``sum_k (x_k - c_k)^2 + strength sum_k (x''_k)^2``, ``x''`` the second divided
    difference over velocity scaled to [0, 1] (irregular spacing allowed). Centres that change linearly with
    velocity come back unchanged; a large ``strength`` tends to the straight line through them; fewer than three
    velocities are left as they are.
    """
    v = np.asarray(velocities, dtype=np.float64)
    x = np.asarray(c, dtype=np.float64)
    n = len(v)
    if n < 3:
        return x.copy()
    h = np.diff((v - v[0]) / (v[-1] - v[0]))
    rows, s = np.arange(n - 2), 2.0 / (h[:-1] + h[1:])
    d2 = np.zeros((n - 2, n))
    d2[rows, rows], d2[rows, rows + 1], d2[rows, rows + 2] = s / h[:-1], -s * (1 / h[:-1] + 1 / h[1:]), s / h[1:]
    return np.linalg.solve(np.eye(n) + strength * d2.T @ d2, x)


def _blend_and_centre(reps, c, velocities, lo: int, hi: int, v: float, penalty: float, paths: dict):
    """At ``v`` between the neighbours ``lo`` and ``hi``: ``w``, the blend of the representatives ``reps`` and the
    morph of the centres ``c``."""
    w = float((v - velocities[lo]) / (velocities[hi] - velocities[lo]))
    return w, (1 - w) * reps[lo] + w * reps[hi], morph(c[lo], c[hi], penalty, paths)(w)


def _predict(reps, c, velocities, lo: int, hi: int, v: float, penalty: float, paths: dict) -> np.ndarray:
    """The profile at ``v`` from the neighbours ``lo`` and ``hi``: representatives ``reps``, centres ``c``."""
    w, blend, centre = _blend_and_centre(reps, c, velocities, lo, hi, v, penalty, paths)
    return blend + 4 * w * (1 - w) * (centre - blend)


@dataclass(frozen=True)
class _Object:
    """What the choices need of one object, computed once per fit."""

    velocities: np.ndarray
    reps: np.ndarray      # representatives (the bank)
    drops: np.ndarray     # every drop (V, D, N)
    centres: np.ndarray   # trimmed drop centres
    means: np.ndarray     # plain drop means: the yardstick of every choice
    noise: np.ndarray     # the centres' sampling variance (jackknife_noise)
    scored: list[int]     # training targets' indices
    rate_hz: float


def _objects(data: TrainingData, trim: float) -> dict[str, _Object]:
    """Every object's :class:`_Object` (its drops trimmed by ``trim``)."""
    out = {}
    for obj, bank in data.banks.items():
        drops = matching_drops(bank, data.drops[obj])
        out[obj] = _Object(bank.velocities, bank.profiles, drops, centres(drops, trim), drops.mean(axis=1),
                           jackknife_noise(drops, trim), training_targets(data, obj), bank.rate_hz)
    return out


def _choose(scores: dict, options: tuple, fallback):
    """Per object its option with the lowest mean score when it has :data:`MIN_FOLDS` folds, else the pooled
    option (best over every object's folds; ``fallback`` with none); the pooled option; the mean scores."""
    pooled_scores = {o: [x for own in scores.values() for x in own[o]] for o in options}
    pooled = min(options, key=lambda o: np.mean(pooled_scores[o])) if pooled_scores[options[0]] else fallback
    chosen = {obj: min(options, key=lambda o: np.mean(own[o])) if len(own[options[0]]) >= MIN_FOLDS else pooled
              for obj, own in scores.items()}
    means = {obj: {o: float(np.mean(v)) for o, v in own.items()} for obj, own in scores.items() if own[options[0]]}
    return chosen, pooled, means


def _rmse(a, b) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def penalty_folds(objects: dict[str, _Object], paths: dict) -> dict[str, dict[float, list[float]]]:
    """Per object and penalty, the RMSE of each training target left out and predicted from its neighbours'
    centres, against the mean of its drops: what each object's penalty is chosen by (:func:`_choose`; an object
    with fewer than :data:`MIN_FOLDS` folds takes the pooled best, no warp when no object has a fold)."""
    return {obj: {p: [_rmse(_predict(o.reps, o.centres, o.velocities, i - 1, i + 1, o.velocities[i], p, paths),
                            o.means[i]) for i in o.scored] for p in PENALTIES}
            for obj, o in objects.items()}


def _left_out_targets(o: _Object, penalty: float, paths: dict, pool, *, middle: bool = False):
    """Each of ``o``'s training targets ``i`` left out, from the centres of the velocities that remain as
    ``pool(velocities, centres, noise)`` pools them: ``(i, w, blend, centre)`` (:func:`_blend_and_centre`), and
    with ``middle`` the blend and centre halfway between its neighbours too."""
    for i in o.scored:
        keep = np.arange(len(o.velocities)) != i
        v, c, reps = o.velocities[keep], pool(o.velocities[keep], o.centres[keep], o.noise[keep]), o.reps[keep]
        # in the kept arrays, i's neighbours are i - 1 and i
        found = (i, *_blend_and_centre(reps, c, v, i - 1, i, o.velocities[i], penalty, paths))
        yield (*found, _blend_and_centre(reps, c, v, i - 1, i, 0.5 * (v[i - 1] + v[i]), penalty, paths)[1:]) \
            if middle else found


def _left_out(o: _Object, penalty: float, paths: dict, pool) -> list[float]:
    """Each of ``o``'s training targets left out and predicted (:func:`_left_out_targets`): the RMSE against the
    target's drop mean, per target."""
    return [_rmse(blend + 4 * w * (1 - w) * (centre - blend), o.means[i])
            for i, w, blend, centre in _left_out_targets(o, penalty, paths, pool)]


def choose_shrink(objects: dict[str, _Object], penalties: dict[str, float],
                  folds: dict[str, dict[float, list[float]]], paths: dict):
    """Whether each object's centres are shrunk (:func:`shrunk_centres`), the pooled choice, the mean scores and
    every fold's scores (what :func:`choose_smoothing` compares with).

    As the penalty is chosen, with the object's penalty: each training target left out is predicted from its
    neighbours' centres as they are (the penalty's own folds) and shrunk among the velocities that remain.
    """
    scores = {}
    for obj, o in objects.items():
        p = penalties[obj]
        shrunk = _left_out(o, p, paths, lambda v, c, noise: shrunk_centres(v, c, noise, p, paths))
        scores[obj] = {False: folds[obj][p], True: shrunk}
    return (*_choose(scores, SHRINK, False), scores)


def choose_smoothing(objects: dict[str, _Object], penalties: dict[str, float], shrink: dict[str, bool],
                     shrink_folds: dict[str, dict[bool, list[float]]], paths: dict):
    """Whether each object the warp left out has its centres smoothed (:func:`smoothed_centres`) and how strongly
    (``None``: not; the centres as :func:`choose_shrink` left them), the pooled choice, and the mean scores.

    Each training target left out is predicted from the smoothed centres of the velocities that remain, as
    :func:`choose_shrink` scores; a warped object is not smoothed.
    """
    scores = {}
    for obj, o in objects.items():
        if np.isfinite(penalties[obj]):
            continue
        scores[obj] = {None: shrink_folds[obj][shrink[obj]],
                       **{s: _left_out(o, penalties[obj], paths, lambda v, c, _, s=s: smoothed_centres(v, c, s))
                          for s in SMOOTHING}}
    chosen, pooled, means = _choose(scores, (None, *SMOOTHING), None)
    return {obj: chosen.get(obj) for obj in objects}, pooled, means


def texture_targets(objects: dict[str, _Object], penalties: dict[str, float], pools: dict, paths: dict):
    """Every object's training targets, each left out and predicted as the fit predicts it (the object's penalty,
    its centres pooled as ``pools[obj](velocities, centres, noise)`` among the velocities that remain, filled as
    at the middle of its interval), as :func:`hapticfx.interpolators.texture.choose` takes them."""
    for obj, o in objects.items():
        for i, w, blend, centre, (mid_blend, mid_centre) in _left_out_targets(o, penalties[obj], paths, pools[obj],
                                                                              middle=True):
            yield Target(w, blend, centre - blend, o.drops[i], o.means[i], o.reps[i], o.rate_hz,
                         at=(mid_blend, mid_centre - mid_blend))


def choose_pull(targets: list[Target], pulls=PULLS) -> tuple[int, dict[int, float]]:
    """The pull ``p`` (:func:`~hapticfx.interpolators.residual.lift`) whose profiles, at every left-out training
    target, come nearest its drop mean (mean RMSE; the least ``p`` on a tie), and each ``p``'s mean RMSE. With no
    targets (no object has an interior training velocity) the least ``p``, and no scores."""
    if not targets:
        return min(pulls), {}
    scores = {p: float(np.mean([_rmse(t.blend + pull(t.w, p) * t.diff, t.mean) for t in targets]))
              for p in pulls}
    return min(pulls, key=lambda p: (scores[p], p)), scores


class Fit:
    """What the method learned from ``data``: ``trim``, every object's ``penalties`` and drop centres, the
    dataset's ``texture`` and ``fill``; the morph of each recorded interval is made on first use. ``trim`` and
    ``texture`` None: chosen; ``fill`` None: chosen with the texture, from :data:`FILLS`; ``pull`` None: chosen from
    :data:`PULLS` (:func:`choose_pull`), before the texture."""

    def __init__(self, data: TrainingData, *, trim: float | None = None, texture: float | None = None,
                 fill: float | None = None, pull: int | None = None):
        missing = [obj for obj in data.banks if obj not in data.drops]
        if missing:
            raise DatasetError(f"the {NAME} interpolator needs every recorded drop; dataset {data.dataset!r} keeps "
                               f"only representative profiles of {', '.join(missing)} (no raw/ recordings); "
                               "use interpolator: linear")
        self.data = data
        self.trim_scores = None
        self.trim = trim
        if trim is None:
            self.trim, self.trim_scores = ensemble.choose_trim(data, against="mean")
        paths: dict = {}  # the alignments of this fit, shared by its choices and kept by a shrunk object's pool
        objects = _objects(data, self.trim)
        folds = penalty_folds(objects, paths)
        self.penalties, self.pooled_penalty, self.penalty_scores = _choose(folds, PENALTIES, float("inf"))
        self.shrink, self.pooled_shrink, self.shrink_scores, shrink_folds = choose_shrink(objects, self.penalties,
                                                                                          folds, paths)
        self.smooth, self.pooled_smooth, self.smooth_scores = choose_smoothing(objects, self.penalties, self.shrink,
                                                                               shrink_folds, paths)
        pools = {obj: self._pool(obj, paths) for obj in objects}
        targets = list(texture_targets(objects, self.penalties, pools, paths))
        self.pull, self.pull_scores = choose_pull(targets, PULLS if pull is None else (pull,))
        self.texture, self.fill, self.fill_chosen, self.texture_scores = texture, fill, fill is None, None
        if texture is None or fill is None:
            (self.texture, self.fill), self.texture_scores = choose_texture(
                [replace(t, lift=float(lift(t.w, self.pull))) for t in targets],
                betas=TEXTURES if texture is None else (texture,), fills=FILLS if fill is None else (fill,))
        self.centres = {obj: pools[obj](o.velocities, o.centres, o.noise) for obj, o in objects.items()}
        self._objects, self._pools = objects, pools
        self._rate = {obj: o.rate_hz for obj, o in objects.items()}
        self.unwarped: list[tuple[str, int]] = []  # intervals a table serves without their warp (:meth:`unwarp`)
        self._morphs: dict[tuple[str, int], Morph] = {}
        self._fills: dict[tuple[str, int], np.ndarray] = {}  # each interval's fill, as at its middle
        self._index = {(obj, float(v)): i for obj, bank in data.banks.items() for i, v in enumerate(bank.velocities)}

    def centres_without(self, obj: str, i: int) -> np.ndarray:
        """``obj``'s centres pooled as fitted from every recorded velocity but ``i``: ``(V - 1, N)``, what a
        left-out training target's neighbours would be had ``i`` not been recorded."""
        o = self._objects[obj]
        keep = np.arange(len(o.velocities)) != i
        return self._pools[obj](o.velocities[keep], o.centres[keep], o.noise[keep])

    def _pool(self, obj: str, paths: dict):
        """How ``obj``'s choices pool its centres, as ``pool(velocities, centres, noise)``: smoothed, shrunk or
        as they are."""
        if self.smooth[obj] is not None:
            return lambda v, c, noise: smoothed_centres(v, c, self.smooth[obj])
        if self.shrink[obj]:
            return lambda v, c, noise: shrunk_centres(v, c, noise, self.penalties[obj], paths)
        return lambda v, c, noise: c

    def morph(self, obj: str, i: int) -> Morph:
        """The morph from the centre at recorded velocity ``i`` of ``obj`` to the one at ``i + 1``."""
        key = (obj, i)
        if key not in self._morphs:
            penalty = float("inf") if key in self.unwarped else self.penalties[obj]
            self._morphs[key] = morph(self.centres[obj][i], self.centres[obj][i + 1], penalty)
        return self._morphs[key]

    def unwarp(self, obj: str, i: int) -> None:
        """Blend ``obj``'s centres ``i`` and ``i + 1`` without their warp from now on. Where the alignment moves an
        event by nearly as much as the event lasts, the morph turns sharply near ``w`` = 1 and no table of
        reasonable size follows it (:func:`hapticfx.interpolators.table.tabulate_interval`); that interval is
        then served as ``ensemble`` serves it, and the fit says so (``unwarped`` in its summary)."""
        self.unwarped.append((obj, i))
        self._morphs.pop((obj, i), None)
        self._fills.pop((obj, i), None)

    def residual(self, obj: str, v_lo: float, lower: np.ndarray, upper: np.ndarray, w: float) -> np.ndarray:
        """``r`` of :mod:`hapticfx.interpolators.residual` at ``w`` between ``lower`` (at ``v_lo``) and ``upper``."""
        return lift(w, self.pull) * self.bump_residual(obj, v_lo, lower, upper, w)

    def bump_residual(self, obj: str, v_lo: float, lower: np.ndarray, upper: np.ndarray, w: float) -> np.ndarray:
        """The residual as the bump would draw the profile toward it (:meth:`residual` over the pull's
        :func:`~hapticfx.interpolators.residual.lift`): what a table stores, weighing it by the pull at a lookup."""
        i = self._index[(obj, float(v_lo))]
        blend = (1 - w) * lower + w * upper
        kept = keep_texture(self.morph(obj, i)(w) - blend, self.texture, self._rate[obj])
        return (kept + self._fill(obj, i, lower, upper)) / scale(lower, upper)

    def _fill(self, obj: str, i: int, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | float:
        """What the fill adds to the centre all along ``obj``'s interval ``i``: its fill at the middle
        (:func:`~hapticfx.interpolators.texture.filling`); 0 without a fill."""
        if not self.fill:
            return 0.0
        if (obj, i) not in self._fills:
            blend = 0.5 * (lower + upper)
            self._fills[(obj, i)] = filling(blend, self.morph(obj, i)(0.5) - blend, self.texture, self.fill,
                                            self._rate[obj])
        return self._fills[(obj, i)]

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

        return {"trim": self.trim, "texture": self.texture, "fill": self.fill, "pull": self.pull,
                "penalty": {obj: name(p) for obj, p in self.penalties.items()},
                "pooled_penalty": name(self.pooled_penalty),
                "warped_objects": sum(bool(np.isfinite(p)) for p in self.penalties.values()),
                "shrink": dict(self.shrink), "pooled_shrink": self.pooled_shrink,
                "shrunk_objects": sum(self.shrink.values()),
                "smooth": dict(self.smooth), "pooled_smooth": self.pooled_smooth,
                "smoothed_objects": sum(s is not None for s in self.smooth.values()),
                "unwarped": [f"{obj} {v[i]:g}-{v[i + 1]:g} m/s" for obj, i in self.unwarped
                             for v in [self.data.banks[obj].velocities]],
                "loo_rmse": self.trim_scores,
                "penalty_loo_rmse": {obj: {("inf" if not np.isfinite(p) else str(p)): x for p, x in own.items()}
                                     for obj, own in self.penalty_scores.items()},
                "shrink_loo_rmse": {obj: {str(k).lower(): x for k, x in own.items()}
                                    for obj, own in self.shrink_scores.items()},
                "smooth_loo_rmse": {obj: {("none" if k is None else str(k)): x for k, x in own.items()}
                                    for obj, own in self.smooth_scores.items()},
                "pull_loo_rmse": {str(p): x for p, x in self.pull_scores.items()},
                "texture_loo": self.texture_scores}


def table_path(dataset_path: Path, reducer: str) -> Path:
    """Where a dataset keeps its fitted ensemble-warp table for ``reducer``."""
    return Path(dataset_path) / "tables" / f"{NAME}-{reducer}.table.npz"


def tabulate(fit: Fit, *, progress=None) -> VelocityTable:
    """``fit`` as a velocity table (every object and interval of its data)."""
    def residual(lower, upper, v_lo, v_hi, v, obj):
        return np.stack([fit.bump_residual(obj, v_lo[k], lower[k], upper[k], (v[k] - v_lo[k]) / (v_hi[k] - v_lo[k]))
                         for k in range(len(v))])

    table = build_table(fit.data.banks.values(), residual, interpolator=NAME,
                        source={"trim": fit.trim, "texture": fit.texture,
                                "fill": CHOOSE if fit.fill_chosen else fit.fill, "pull": fit.pull,
                                "penalty": fit.summary()["penalty"],
                                "shrink": dict(fit.shrink), "smooth": dict(fit.smooth)},
                        dataset=fit.data.dataset, tolerance=TOLERANCE, progress=progress, on_rough=fit.unwarp,
                        pull_power=fit.pull)
    table.meta["fit"] = fit.summary()
    return table


def fit_table(data: TrainingData, *, trim: float | None = None, texture: float | None = None,
              fill: float | str = CHOOSE) -> VelocityTable:
    """The ensemble-warp's velocity table for every object of ``data`` (``trim`` and ``texture`` chosen where not
    given, ``fill`` where it is :data:`CHOOSE`). Its source records the fill as asked: a number, or
    :data:`CHOOSE` (what was chosen is in its fit's summary)."""
    return tabulate(Fit(data, trim=trim, texture=texture, fill=None if fill == CHOOSE else fill))


class EnsembleWarpInterpolator(EnsembleInterpolator):
    """The ensemble with its neighbours' drop centres aligned in time before they blend (see the module docs).
    Options as ``ensemble``'s (``table``, ``trim``), ``texture`` (fix the share of the representatives' fine
    detail kept, 0 to 1, instead of the fitted one; the table is then fitted when the effect loads) and ``fill``
    (``choose``, the default: chosen with the texture; a number from 0 to 1 fixes ``g``, 0: no fill).

    After :meth:`fit` (an evaluation) it answers directly from what it fitted; an effect serves it from its
    table (the dataset's ``tables/ensemble-warp-<reducer>.table.npz``, or tabulated when the effect loads).
    """

    name = NAME
    fitted: Fit | None = None

    fit_table = staticmethod(fit_table)
    table_path = staticmethod(table_path)

    def __init__(self, *, table=None, trim: float | None = None, texture: float | None = None,
                 fill: float | str = CHOOSE):
        super().__init__(table=table, trim=trim)
        self.texture = None if texture is None else valid_number(texture, name="interpolator_options.texture",
                                                                 minimum=0.0, maximum=1.0)
        if isinstance(fill, str) and fill != CHOOSE:
            raise SignalError(f"interpolator_options.fill must be a number from 0 to 1 or {CHOOSE!r}, got {fill!r}")
        self.fill = fill if fill == CHOOSE else valid_number(fill, name="interpolator_options.fill", minimum=0.0,
                                                             maximum=1.0)

    def fixed(self) -> dict:
        return {**super().fixed(), "texture": self.texture, "fill": self.fill}

    def fit(self, data: TrainingData, **options) -> dict:
        fixed = self.fixed()
        fixed["fill"] = None if self.fill == CHOOSE else self.fill
        self.fitted, self.table = Fit(data, **fixed), None
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
        if self.table is None:
            return {}
        source = self.table.meta["source"]
        return {**super().describe(),
                "warp penalty": {obj: "none" if p is None else p for obj, p in source["penalty"].items()},
                "texture": source.get("texture", 0.0),  # none in a table written before the texture
                "pull": source.get("pull", 2),  # none in a table written before the pull was chosen: the bump
                "fill": self.table.meta["fit"].get("fill", 0.0),
                "centres shrunk": {obj: "yes" if shrunk else "no" for obj, shrunk in source["shrink"].items()},
                "centres smoothed": {obj: "no" if s is None else s  # none in a table written before smoothing
                                     for obj, s in source.get("smooth", {}).items()}}


__all__ = ["EnsembleWarpInterpolator", "Fit", "choose_pull", "choose_shrink", "choose_smoothing", "fit_table",
           "jackknife_noise", "morph", "penalty_folds", "shrunk_centres", "smoothed_centres", "tabulate", "table_path",
           "texture_targets", "CHOOSE", "MIN_FOLDS", "PENALTIES", "PULLS", "SHRINK", "SMOOTHING", "TOLERANCE"]
