"""Training triples from every recorded drop, and the network's input encoding (numpy only).

A triple is (lower neighbour, upper neighbour, velocity) -> the profile at that velocity.
Each recorded velocity is a *pool*: all its drops (reduced like the bank), or the bank's one
representative where a dataset keeps no raw recordings.

What the network sees and predicts:

- **Centre** of a velocity: the per-sample trimmed mean of its drops, ``trim`` of them cut at
  each end (the core's :func:`hapticfx.interpolators.ensemble.centres`; ``trim: 0``, the
  default, is the mean).
- **Inputs**: the centres of the two neighbours. In training, each epoch draws each
  neighbour's centre from a random subset of its drops (at least half of them), so the
  network sees the centres' own sampling noise and never the same input twice; at inference
  the centre is that of every drop. With ``input_drops`` K (pre-training on a rig recorded
  many more times than a user records), a neighbour's centre is that of K drops or fewer
  (K/2 to K drawn at random from all of them in training, the first K for validation) while the target
  stays the centre of every drop: the network learns from clean targets what it will be
  given from K recorded drops. A range ``[fewest, most]`` draws that many instead (for users who
  record as few as ``fewest``), and validation takes one draw per pool in that range, fixed by a seed.
- **Pooled inputs** (``inputs: pooled``): the neighbours' centres as ``ensemble-warp`` pools them across
  velocity, fixed per triple (``given``; :mod:`.pooled`), instead of drawn from their drops.
- **Target**: the centre of the target velocity's drops. With ``trim: 0`` its RMSE differs
  from the mean RMSE over every drop by a constant, so it *is* a loss over every drop,
  computed once.
- **Normalisation**, per impact: inputs and target divided by ``s = max(|lower|, |upper|)``
  of the two input centres.
- **Output**: a correction ``r`` to the blend of the centres, ``centre(w) = (1 - w) Lc + w Uc + s r``.
  The velocity enters the last dense layer only, as ``w = (v - v_lower) / (v_upper - v_lower)``
  and the standardised absolute velocity, so ``r`` is affine in ``w`` within an interval.
- **Served** in the core's endpoint-consistent form (:mod:`hapticfx.interpolators.residual`),
  drawn from the neighbours' representatives ``L, U`` toward the predicted centre::

      profile = (1 - w) L + w U + 4 w (1 - w) (centre(w) - ((1 - w) L + w U))

  so a recorded velocity returns its representative exactly, and halfway the profile is the
  network's centre. The table residual is affine in ``w``: two nodes per interval are exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hapticfx.errors import DatasetError
from hapticfx.interfaces import Profile
from hapticfx.interpolators.ensemble import centres as trimmed_centres
from hapticfx.interpolators.residual import scale as neighbour_scale, weight

FIXED_INPUT_SEED = 31  # seeds the one fixed draw of each pool's inputs when input_drops is a range


@dataclass
class Triples:
    """Stacked triples: representatives ``lower, upper`` and centres ``lower_c, upper_c`` ``(n, N)``;
    ``v_lo, v_hi, v (n,)``; the target centre ``(n, N)`` (or None); object ids."""

    lower: np.ndarray
    upper: np.ndarray
    lower_c: np.ndarray
    upper_c: np.ndarray
    v_lo: np.ndarray
    v_hi: np.ndarray
    v: np.ndarray
    target: np.ndarray | None
    objects: list[str]

    def __len__(self) -> int:
        return int(self.v.shape[0])

    def subset(self, idx) -> "Triples":
        idx = np.asarray(idx, dtype=int)
        return Triples(self.lower[idx], self.upper[idx], self.lower_c[idx], self.upper_c[idx], self.v_lo[idx],
                       self.v_hi[idx], self.v[idx], None if self.target is None else self.target[idx],
                       [self.objects[i] for i in idx])


def stack_triples(rows: list[tuple[Profile, Profile, float, np.ndarray | None]], objects: list[str],
                  centres=None) -> Triples:
    """Triples for inference from ``(lower, upper, velocity, target)`` rows.

    ``centres(profile) -> centre`` gives a neighbour's drop centre (default: the profile itself).
    """
    find = centres or (lambda p: np.asarray(p.samples, np.float64))
    lower = np.stack([np.asarray(r[0].samples, np.float64) for r in rows])
    upper = np.stack([np.asarray(r[1].samples, np.float64) for r in rows])
    target = None if rows[0][3] is None else np.stack([np.asarray(r[3], np.float64) for r in rows])
    return Triples(lower, upper, np.stack([find(r[0]) for r in rows]), np.stack([find(r[1]) for r in rows]),
                   np.array([r[0].velocity for r in rows], float), np.array([r[1].velocity for r in rows], float),
                   np.array([r[2] for r in rows], float), target, list(objects))


@dataclass
class DropTriples:
    """Triples over pools of drops: ``pools[k]`` is ``(D_k, N)``; ``lo, hi, tgt`` index pools per triple;
    ``trim``: the fraction of drops cut at each end for a pool's centre (0: the mean); ``input_drops``: how many
    drops an input centre is drawn from: None (half to all of its pool), K (half of K to K) or ``(fewest, most)``;
    ``reps[k]``: the bank's
    representative of pool ``k`` and ``rate_hz`` the banks' rate, where known (what a profile is served from,
    and what choosing its texture needs); ``given``: each triple's inputs ``(lower (n, N), upper (n, N))`` where
    they are not drawn from the pools (pooled inputs, :mod:`.pooled`)."""

    pools: list[np.ndarray]
    lo: np.ndarray
    hi: np.ndarray
    tgt: np.ndarray
    v_lo: np.ndarray
    v_hi: np.ndarray
    v: np.ndarray
    objects: list[str]
    trim: float = 0.0
    input_drops: int | tuple[int, int] | None = None
    reps: list[np.ndarray] | None = None
    rate_hz: float | None = None
    given: tuple[np.ndarray, np.ndarray] | None = None

    def __len__(self) -> int:
        return int(self.v.shape[0])

    @property
    def n_samples(self) -> int:
        return int(self.pools[0].shape[-1])

    def subset(self, idx) -> "DropTriples":
        idx = np.asarray(idx, dtype=int)
        return DropTriples(self.pools, self.lo[idx], self.hi[idx], self.tgt[idx], self.v_lo[idx], self.v_hi[idx],
                           self.v[idx], [self.objects[i] for i in idx], self.trim, self.input_drops, self.reps,
                           self.rate_hz, None if self.given is None else (self.given[0][idx], self.given[1][idx]))

    def input_counts(self, k: int) -> tuple[int, int]:
        """How many of pool ``k``'s drops an input centre is drawn from in training: ``(fewest, most)``."""
        n = len(self.pools[k])
        spec = self.input_drops
        if spec is None or isinstance(spec, int):
            most = n if spec is None else min(n, spec)
            return (most + 1) // 2, most
        return min(n, spec[0]), min(n, spec[1])

    def fixed_inputs(self, k: int) -> np.ndarray:
        """The drops of pool ``k`` whose centre is its input outside training (validation, scoring): every drop,
        the first ``input_drops`` K, or, for a range ``[fewest, most]``, one draw in that range fixed by ``k``."""
        pool, spec = self.pools[k], self.input_drops
        if spec is None or isinstance(spec, int):
            return pool if spec is None else pool[:spec]
        rng = np.random.default_rng([FIXED_INPUT_SEED, k])
        fewest, most = self.input_counts(k)
        return pool[np.sort(rng.choice(len(pool), int(rng.integers(fewest, most + 1)), replace=False))]

    def centres(self, rng: np.random.Generator | None = None) -> Triples:
        """Triples whose inputs are the pools' centres; with ``rng``, each that of a random subset of its drops
        (:meth:`input_counts` of them, drawn from every drop of the pool); without ``rng``, that of
        :meth:`fixed_inputs`."""
        full = [pool_centre(p, self.trim) for p in self.pools]
        if self.given is not None:
            lc, uc = self.given
            return Triples(lc, uc, lc, uc, self.v_lo, self.v_hi, self.v, np.stack([full[k] for k in self.tgt]),
                           self.objects)
        fixed: dict[int, np.ndarray] = {}  # computed for the pools that need it: every input without rng

        def centre(k: int) -> np.ndarray:
            fewest, most = self.input_counts(k)
            if rng is None or most < 2:
                if k not in fixed:
                    fixed[k] = pool_centre(self.fixed_inputs(k), self.trim)
                return fixed[k]
            size = int(rng.integers(fewest, most + 1))
            return pool_centre(self.pools[k][rng.choice(len(self.pools[k]), size, replace=False)], self.trim)

        lc = np.stack([centre(k) for k in self.lo])
        uc = np.stack([centre(k) for k in self.hi])
        return Triples(lc, uc, lc, uc, self.v_lo, self.v_hi, self.v, np.stack([full[k] for k in self.tgt]),
                       self.objects)


def pool_centre(pool: np.ndarray, trim: float) -> np.ndarray:
    """The centre ``(N,)`` of a pool of drops ``(D, N)``: the per-sample trimmed mean (``trim`` 0: the mean)."""
    return pool.mean(axis=0) if trim == 0 else trimmed_centres(pool[None], trim)[0]


def drop_triples(pools_of: list[tuple[str, np.ndarray, list[np.ndarray], list[float]]], *,
                 gaps: list[int], trim: float = 0.0, reps: list[np.ndarray] | None = None,
                 rate_hz: float | None = None) -> DropTriples:
    """Triples of every object: ``(object, velocities (V,), pools, target velocities)``; ``reps``: each
    object's representatives ``(V, N)`` (its bank's profiles), in the same order, where known.

    Target velocity ``i`` takes neighbours ``i - a`` and ``i + b`` for every ``a, b`` in ``gaps``
    (1: the adjacent recorded velocities; on a dense grid larger gaps add wider intervals and
    off-centre positions ``w``).
    """
    pools, lo, hi, tgt, vl, vh, vv, objs = [], [], [], [], [], [], [], []
    for obj, velocities, obj_pools, targets in pools_of:
        base = len(pools)
        pools.extend(np.asarray(p, np.float64) for p in obj_pools)
        for t in targets:
            i = int(np.flatnonzero(np.isclose(velocities, t, rtol=0, atol=1e-9))[0])
            for a in gaps:
                for b in gaps:
                    if i - a < 0 or i + b >= len(velocities):
                        continue
                    lo.append(base + i - a)
                    hi.append(base + i + b)
                    tgt.append(base + i)
                    vl.append(velocities[i - a])
                    vh.append(velocities[i + b])
                    vv.append(velocities[i])
                    objs.append(obj)
    if not tgt:
        raise DatasetError("no training triples: a target needs a recorded velocity on each side")
    lengths = {p.shape[-1] for p in pools}
    if len(lengths) != 1:
        raise DatasetError(f"profiles of different lengths ({sorted(lengths)}) cannot train one network")
    as_int = lambda x: np.array(x, dtype=int)  # noqa: E731
    kept = None if reps is None else [np.asarray(p, np.float64) for r in reps for p in r]
    return DropTriples(pools, as_int(lo), as_int(hi), as_int(tgt), np.array(vl, float), np.array(vh, float),
                       np.array(vv, float), objs, trim, reps=kept, rate_hz=rate_hz)


def concat(parts: list[DropTriples]) -> DropTriples:
    if len({p.trim for p in parts}) > 1:
        raise DatasetError("triples with different centre trims cannot train one network")
    rates = {p.rate_hz for p in parts}
    if len(rates) > 1:
        raise DatasetError(f"datasets at different rates ({', '.join(str(r) for r in sorted(rates, key=str))} Hz) "
                           "cannot train one network")
    pools, offset, idx = [], 0, {"lo": [], "hi": [], "tgt": []}
    for p in parts:
        for k in idx:
            idx[k].append(getattr(p, k) + offset)
        pools.extend(p.pools)
        offset += len(p.pools)
    reps = None if any(p.reps is None for p in parts) else [r for p in parts for r in p.reps]
    if len({p.given is None for p in parts}) > 1:
        raise DatasetError("triples with pooled and with raw inputs cannot train one network")
    given = None if parts[0].given is None else tuple(np.concatenate([p.given[j] for p in parts]) for j in (0, 1))
    return DropTriples(pools, *(np.concatenate(idx[k]) for k in ("lo", "hi", "tgt")),
                       *(np.concatenate([getattr(p, k) for p in parts]) for k in ("v_lo", "v_hi", "v")),
                       sum((p.objects for p in parts), []), parts[0].trim, reps=reps, rate_hz=rates.pop(),
                       given=given)


def encode(t: Triples, *, steps: int, v_mean: float, v_std: float):
    """Network inputs ``x (n, steps, 2, N/steps)``, ``vel (n, 2)`` and the normalised target ``y`` (or None)."""
    n, length = t.lower_c.shape
    if length % steps:
        raise DatasetError(f"profiles of {length} samples cannot be cut into {steps} equal steps; "
                           "choose model.steps dividing the profile length")
    s = neighbour_scale(t.lower_c, t.upper_c)
    width = length // steps
    pair = np.stack([t.lower_c, t.upper_c], axis=1) / s[:, None, None]           # (n, 2, N)
    x = pair.reshape(n, 2, steps, width).transpose(0, 2, 1, 3)                    # (n, T, 2, S)
    vel = np.stack([weight(t.v_lo, t.v_hi, t.v), (t.v - v_mean) / v_std], axis=1)
    y = None if t.target is None else (t.target / s[:, None]).reshape(n, steps, width)
    return x.astype(np.float32), vel.astype(np.float32), None if y is None else y.astype(np.float32)


def centre_of(t: Triples, correction: np.ndarray) -> np.ndarray:
    """The predicted centre ``(n, N)`` in the bank's units from the network's correction ``(n, T, S)``."""
    r = np.asarray(correction, dtype=np.float64).reshape(len(t), -1)
    w = weight(t.v_lo, t.v_hi, t.v)[:, None]
    return (1.0 - w) * t.lower_c + w * t.upper_c + neighbour_scale(t.lower_c, t.upper_c)[:, None] * r


def table_residual(t: Triples, correction: np.ndarray, texture: dict | None = None) -> np.ndarray:
    """The core's residual ``(n, N)`` (:mod:`hapticfx.interpolators.residual`) that serves the prediction, keeping
    ``texture["share"]`` of the representatives' fine detail (:func:`hapticfx.interpolators.texture.keep`; a
    checkpoint's ``meta["texture"]``, None: none). Linear in the correction, so still affine in ``w``."""
    from hapticfx.interpolators.texture import keep

    w = weight(t.v_lo, t.v_hi, t.v)[:, None]
    blend = (1.0 - w) * t.lower + w * t.upper
    diff = centre_of(t, correction) - blend
    if texture:
        diff = keep(diff, texture["share"], texture["rate_hz"])
    return diff / neighbour_scale(t.lower, t.upper)[:, None]


def decode(t: Triples, correction: np.ndarray, texture: dict | None = None) -> np.ndarray:
    """Profiles ``(n, N)`` (float64, bank units): the representatives' blend drawn toward the predicted centre."""
    from hapticfx.interpolators.residual import compose

    return compose(t.lower, t.upper, weight(t.v_lo, t.v_hi, t.v), table_residual(t, correction, texture))


def object_pools(bank, drops) -> list[np.ndarray]:
    """One pool per recorded velocity of ``bank``: its drops ``(D, N)`` from ``drops = (velocities, (V, D, N))``,
    or the representative alone where ``drops`` is None (a dataset without raw recordings)."""
    if drops is None:
        return [np.asarray(p, np.float64)[None] for p in bank.profiles]
    velocities, reduced = drops
    idx = [np.flatnonzero(np.isclose(velocities, v, rtol=0, atol=1e-9)) for v in bank.velocities]
    if any(i.size != 1 for i in idx):
        raise DatasetError(f"object {bank.object!r}: the recorded drops and the bank list different velocities")
    return [np.asarray(reduced[int(i[0])], np.float64) for i in idx]


class Centres:
    """A neighbour's drop centre (trimmed by ``trim``) found from its representative (velocity and samples),
    for inference."""

    def __init__(self, trim: float = 0.0):
        self.trim = float(trim)
        self._by_key: dict[tuple, np.ndarray] = {}

    @classmethod
    def of(cls, meta: dict) -> "Centres":
        """The centres a checkpoint was trained on (``meta["dataset"]["trim"]``; 0 where it was not recorded)."""
        return cls(meta["dataset"].get("trim", 0.0))

    @staticmethod
    def _key(velocity: float, samples: np.ndarray) -> tuple:
        return float(velocity), hash(np.ascontiguousarray(samples, np.float64).tobytes())

    def set(self, bank, centres: np.ndarray) -> None:
        """``centres[k]`` is the input for ``bank``'s representative ``k`` (pooled inputs)."""
        for v, profile, c in zip(bank.velocities, bank.profiles, centres):
            self._by_key[self._key(v, profile)] = np.asarray(c, np.float64)

    def add(self, bank, drops) -> None:
        for v, profile, pool in zip(bank.velocities, bank.profiles, object_pools(bank, drops)):
            self._by_key[self._key(v, profile)] = pool_centre(pool, self.trim)

    def __call__(self, profile: Profile) -> np.ndarray:
        """The centre recorded for ``profile``; the profile itself when its drops are unknown."""
        found = self._by_key.get(self._key(profile.velocity, profile.samples))
        return np.asarray(profile.samples, np.float64) if found is None else found
