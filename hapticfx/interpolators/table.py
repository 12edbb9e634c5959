"""Velocity tables: a learned interpolator served as numbers, without its learning library.

A table holds, for every object of a dataset and every interval between two of
its recorded velocities, the method's residual ``r`` (see
:mod:`hapticfx.interpolators.residual`) at a few positions ``w`` in [0, 1]: the
Chebyshev-Lobatto points of some degree ``d`` (0 and 1 among them). A lookup
evaluates the polynomial through them (barycentric formula) and composes the
profile. The degree is chosen when the table is built: each interval starts at
``d = 1`` (the two ends, a straight line) and doubles ``d`` until the table agrees
with the method itself at the points of degree ``4 d`` (``tolerance``, relative to
the neighbours' larger peak). A method whose residual is affine in velocity (the
neural interpolators, whose velocity enters only their last linear layer, and the
``ensemble`` interpolator) needs only the two ends; a smooth curved one converges
in a few doublings.

A table records what it was built from: the interpolator, a ``source`` (for
example the weights' SHA-256) and each object's bank digest. A table whose source
or bank no longer matches is refused with a message naming the file, so a stale
table can never be served.

File: one ``.npz`` (no pickle) holding ``meta_json`` and, per object ``k`` (in sorted order of ids),
``o<k>.w`` (nodes of all intervals, concatenated), ``o<k>.starts`` (where each
interval's nodes start; one more entry than intervals) and ``o<k>.residual``;
``x.<name>`` for what the table's owner keeps beside it (a physics model's
profiles at its own velocity grid: :mod:`hapticfx.models.physics_table`).

A method whose profile is drawn toward its residual by a flatter pull than the bump,
``1 - |1 - 2w|^p`` (:func:`hapticfx.interpolators.residual.pull`), records ``pull: p`` in the
table's metadata and stores its residual as the bump's form would have it (the residual
over :func:`~hapticfx.interpolators.residual.lift`): a lookup weighs the nodes by the pull,
and the table keeps the bump's node counts. Without the key, ``p`` = 2: the bump.
"""

from __future__ import annotations

import hashlib
import json
import math
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

from ..atomic import atomic_path
from ..data.dataset import UNREADABLE, unreadable
from ..errors import CheckpointError, SignalError
from ..interfaces import Blend, Interpolator, Profile, Term
from ..signal import valid_signal, valid_velocity
from .residual import pull, scale, valid_pull

FORMAT = "hapticfx-interpolator-table"
VERSION = 1
DEFAULT_TOLERANCE = 1e-9
_MAX_DEGREE = 256

# residual_fn(lower (n, N), upper (n, N), v_lo (n,), v_hi (n,), v (n,), object id) -> r (n, N)
ResidualFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, str], np.ndarray]


def bank_digest(bank) -> str:
    """SHA-256 of a bank's rate, velocities and profiles (float64): what a table was built for."""
    h = hashlib.sha256()
    h.update(np.array(bank.rate_hz, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(bank.velocities, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(bank.profiles, dtype="<f8").tobytes())
    return h.hexdigest()


def _short(value) -> str:
    """A value for a message; a digest is cut to its first 12 characters, which tell two apart."""
    return repr(value[:12] + "...") if isinstance(value, str) and len(value) > 16 else repr(value)


def _key(lower: Profile, upper: Profile) -> tuple:
    # Objects of one dataset often share their recorded velocities: the neighbours' samples tell them apart.
    return (float(lower.velocity), float(upper.velocity), hash(lower.samples.tobytes()), hash(upper.samples.tobytes()))


def neighbours(lower: Profile, upper: Profile, velocity: float) -> tuple[Profile, Profile, float]:
    """The gate of a table-served interpolator: finite 1D neighbours of one length, ``velocity`` between them."""
    v = valid_velocity(velocity)
    lo = Profile(valid_velocity(lower.velocity), valid_signal(lower.samples, name="lower profile", ndim=1))
    hi = Profile(valid_velocity(upper.velocity), valid_signal(upper.samples, name="upper profile", ndim=1))
    if not lo.velocity < hi.velocity or not lo.velocity <= v <= hi.velocity:
        raise SignalError(f"velocity {v} m/s must lie between the neighbours {lo.velocity} and {hi.velocity} m/s")
    if lo.samples.shape != hi.samples.shape:
        raise SignalError(f"neighbour profiles differ in length: {lo.samples.shape} vs {hi.samples.shape}")
    return lo, hi, v


@dataclass(frozen=True)
class Interval:
    """The residual of one recorded interval at nodes ``w`` (0 first, 1 last, increasing)."""

    w: np.ndarray
    residual: np.ndarray

    def __post_init__(self):
        diff = self.w[:, None] - self.w[None, :]
        np.fill_diagonal(diff, 1.0)
        object.__setattr__(self, "_bary", 1.0 / diff.prod(axis=1))

    def coefficients(self, w: float) -> np.ndarray:
        """The weight of each node's residual at ``w`` (barycentric; one at a node, zero elsewhere)."""
        d = w - self.w
        hit = np.flatnonzero(d == 0.0)
        if hit.size:
            c = np.zeros(self.w.size)
            c[hit[0]] = 1.0
            return c
        c = self._bary / d
        return c / c.sum()

    def at(self, w: float) -> np.ndarray:
        """The residual at ``w`` (the polynomial through the nodes; a line for two nodes)."""
        return self.coefficients(w) @ self.residual


class VelocityTable:
    """Residuals of one interpolator on a velocity grid, per object and recorded interval.

    Build with :func:`build_table`, read with :meth:`load`. Before serving an
    object, :meth:`attach` checks that its bank is the one the table was built
    from; :meth:`lookup` then answers for that bank's intervals.
    """

    def __init__(self, meta: dict, intervals: dict[str, list[Interval]], *, path: Path | None = None,
                 arrays: dict[str, np.ndarray] | None = None):
        self.meta = meta
        self.intervals = intervals
        self.path = path
        self.arrays = dict(arrays or {})  # what the table's owner keeps beside it (a physics table: its knots)
        self._index: dict[tuple, tuple[str, int, Interval, float]] = {}

    @classmethod
    def of(cls, banks: dict, intervals: dict[str, list[Interval]], *, interpolator: str, source: dict, dataset: str,
           tolerance: float, **extra) -> "VelocityTable":
        """A table of ``intervals`` for ``banks`` (object -> bank, one reducer and profile length)."""
        reducers = {b.reducer for b in banks.values()}
        lengths = {b.n_samples for b in banks.values()}
        if len(reducers) != 1 or len(lengths) != 1:
            raise CheckpointError(f"one table holds banks of one reducer and profile length; got {reducers}, {lengths}")
        meta = {"format": FORMAT, "version": VERSION, "interpolator": interpolator, "source": source,
                "dataset": dataset, "reducer": reducers.pop(), "n_samples": lengths.pop(), "tolerance": tolerance,
                "objects": {obj: {"bank_sha256": bank_digest(b), "velocities": b.velocities.tolist()}
                            for obj, b in banks.items()}, **extra}
        return cls(meta, intervals)

    @property
    def where(self) -> str:
        return str(self.path) if self.path else "velocity table"

    @property
    def pull(self) -> int:
        """The power of the pull the residual nodes are weighed by at a lookup (2: the bump)."""
        return int(self.meta.get("pull", 2))

    @property
    def n_nodes(self) -> int:
        return sum(len(iv.w) for ivs in self.intervals.values() for iv in ivs)

    def check_source(self, interpolator: str, source: dict, *, rebuild: str) -> None:
        """Refuse a table made by another interpolator or from other weights/parameters."""
        if self.meta["interpolator"] != interpolator:
            raise CheckpointError(f"{self.where}: a table of interpolator {self.meta['interpolator']!r}, "
                                  f"not {interpolator!r}")
        made = self.meta["source"]
        for key, value in source.items():
            if made.get(key) != value:
                raise CheckpointError(f"{self.where}: stale: built for {key} {_short(made.get(key))}, now "
                                      f"{_short(value)}; {rebuild}")

    def attach(self, bank, *, rebuild: str) -> None:
        """Check that ``bank`` is the one this table was built from, and index its intervals for lookups."""
        obj = self.meta["objects"].get(bank.object)
        if obj is None:
            raise CheckpointError(f"{self.where}: no table for object {bank.object!r} (has: "
                                  f"{', '.join(self.meta['objects']) or 'none'}); {rebuild}")
        if self.meta["reducer"] != bank.reducer:
            raise CheckpointError(f"{self.where}: built for reducer {self.meta['reducer']!r} banks, "
                                  f"not {bank.reducer!r}; {rebuild}")
        if obj["bank_sha256"] != bank_digest(bank):
            raise CheckpointError(f"{self.where}: stale: the bank of {bank.object!r} changed since the table was "
                                  f"built; {rebuild}")
        for i, iv in enumerate(self.intervals[bank.object]):
            lower, upper = bank[i], bank[i + 1]
            self._index[_key(lower, upper)] = (bank.object, i, iv, float(scale(lower.samples, upper.samples)))

    def blend(self, lower: Profile, upper: Profile, velocity: float) -> Blend | None:
        """The profile at ``velocity`` between two attached neighbours as a :class:`Blend` of the neighbours and
        the interval's residual nodes (``residual.compose`` written out), or None for unknown neighbours.

        Attached neighbours were checked with their bank, so only ``velocity`` is checked here.
        """
        found = self._index.get(_key(lower, upper))
        if found is None:
            return None
        v = valid_velocity(velocity)
        if not lower.velocity <= v <= upper.velocity:
            raise SignalError(f"velocity {v} m/s must lie between the neighbours {lower.velocity} and "
                              f"{upper.velocity} m/s")
        obj, i, iv, s = found
        w = (v - lower.velocity) / (upper.velocity - lower.velocity)
        k = float(pull(w, self.pull)) * s  # residual.pull(w, p) * residual.scale(lower, upper)
        extra = tuple(Term(("table", obj, i, j), k * float(c), iv.residual[j])
                      for j, c in enumerate(iv.coefficients(w)) if c) if k else ()
        return Blend(1.0 - w, w, extra)

    def atoms(self, bank) -> tuple[Term, ...]:
        """Every residual node :meth:`blend` can name between neighbours of ``bank`` (attached)."""
        return tuple(Term(("table", bank.object, i, j), 1.0, row)
                     for i, iv in enumerate(self.intervals.get(bank.object, ())) for j, row in enumerate(iv.residual))

    def lookup(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray | None:
        """The profile at ``velocity`` between two attached neighbours, or None for unknown neighbours."""
        found = self.blend(lower, upper, velocity)
        return None if found is None else found.of(lower, upper)

    # -- file -----------------------------------------------------------------------------
    def save(self, path: str | Path, *, residual_dtype=np.float64) -> Path:
        """Write the table atomically (one ``.npz``, no pickle); residuals as ``residual_dtype`` (read back as
        float64)."""
        path = Path(path)
        arrays = {"meta_json": np.array(json.dumps(self.meta, sort_keys=True))}
        for k, obj in enumerate(sorted(self.meta["objects"])):
            ivs = self.intervals[obj]
            arrays[f"o{k}.w"] = np.concatenate([iv.w for iv in ivs])
            arrays[f"o{k}.starts"] = np.cumsum([0] + [len(iv.w) for iv in ivs]).astype(np.int64)
            arrays[f"o{k}.residual"] = np.concatenate([iv.residual for iv in ivs]).astype(residual_dtype)
        arrays.update({f"x.{name}": value for name, value in self.arrays.items()})
        with atomic_path(path, make_parents=True) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, **arrays)
        self.path = path
        return path

    @classmethod
    def load(cls, path: str | Path, *, rebuild: str | None = None) -> "VelocityTable":
        """Read and validate a table file; anything malformed is a :class:`CheckpointError` naming it.
        ``rebuild``: how to write a table that is not there, said when it is not. Inside :func:`shared_tables`,
        a file read already (same path, size and modification time) gives the table read then."""
        path = Path(path)
        if not path.is_file():
            raise CheckpointError(f"{path}: velocity table not found" + (f"; {rebuild}" if rebuild else ""))
        shared = _SHARED.get()
        if shared is None:
            return cls._read(path)
        stat = path.stat()
        key = (str(path), stat.st_size, stat.st_mtime_ns)
        if key not in shared:
            shared[key] = cls._read(path)
        return shared[key]

    @classmethod
    def _read(cls, path: Path) -> "VelocityTable":
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
            meta = json.loads(str(arrays.pop("meta_json")))
        except UNREADABLE as exc:  # json.JSONDecodeError is a ValueError
            raise CheckpointError(f"{path}: corrupt or unreadable velocity table ({unreadable(exc)})") from None
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise CheckpointError(f"{path}: not a {FORMAT} file")
        if meta.get("version") != VERSION:
            raise CheckpointError(f"{path}: table format version {meta.get('version')!r}; "
                                  f"this hapticfx reads version {VERSION}")
        try:
            extra = {k[2:]: v for k, v in arrays.items() if k.startswith("x.")}
            return cls(meta, _intervals(meta, arrays), path=path, arrays=extra)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise CheckpointError(f"{path}: malformed velocity table ({exc})") from exc

    def describe(self) -> dict:
        return {"table": self.where, "interpolator": self.meta["interpolator"], "objects": len(self.intervals),
                "nodes": self.n_nodes, "tolerance": self.meta["tolerance"]}


_SHARED: ContextVar[dict | None] = ContextVar("hapticfx_shared_tables", default=None)


@contextmanager
def shared_tables() -> Iterator[None]:
    """Within the block, :meth:`VelocityTable.load` reads each table file once: an engine builds its scene's
    entries in one, so that entries served from one dataset's table share one copy (each attaches its own bank).
    """
    token = _SHARED.set({})
    try:
        yield
    finally:
        _SHARED.reset(token)


def _intervals(meta: dict, arrays: dict) -> dict[str, list[Interval]]:
    for key in ("interpolator", "source", "dataset", "reducer", "objects", "n_samples", "tolerance"):
        if key not in meta:
            raise KeyError(f"metadata has no {key!r}")
    if "pull" in meta:
        valid_pull(meta["pull"])
    n = int(meta["n_samples"])
    out = {}
    for k, obj in enumerate(sorted(meta["objects"])):
        info = meta["objects"][obj]
        w, starts, res = arrays[f"o{k}.w"], arrays[f"o{k}.starts"], arrays[f"o{k}.residual"]
        n_iv = len(info["velocities"]) - 1
        if starts.shape != (n_iv + 1,) or starts[0] != 0 or starts[-1] != len(w) or res.shape != (len(w), n):
            raise ValueError(f"object {obj!r}: arrays do not match its {n_iv} intervals of {n}-sample profiles")
        if w.dtype.kind != "f" or res.dtype.kind != "f" or not (np.all(np.isfinite(w)) and np.all(np.isfinite(res))):
            raise ValueError(f"object {obj!r}: nodes and residuals must be finite floats")
        ivs = []
        for a, b in zip(starts[:-1], starts[1:]):
            node = w[a:b]
            if len(node) < 2 or node[0] != 0.0 or node[-1] != 1.0 or np.any(np.diff(node) <= 0):
                raise ValueError(f"object {obj!r}: each interval needs nodes from 0 to 1, increasing")
            ivs.append(Interval(node.astype(np.float64), res[a:b].astype(np.float64)))
        out[obj] = ivs
    return out


def build_table(banks: Iterable, residual_fn: ResidualFn, *, interpolator: str, source: dict, dataset: str,
                tolerance: float = DEFAULT_TOLERANCE, progress: Callable[[str], None] | None = None,
                on_rough: Callable[[str, int], None] | None = None, pull_power: int = 2) -> VelocityTable:
    """Tabulate ``residual_fn`` over every recorded interval of ``banks`` (one per object, one reducer).

    Each interval starts with the nodes ``w`` = 0 and 1 and doubles the number of
    Chebyshev-Lobatto nodes until the polynomial through them misses the method by
    at most ``tolerance`` (relative to the neighbours' larger peak) at the points of
    four times the degree. An interval that does not get there is refused, unless the
    method has a smoother form for it: ``on_rough(object, i)`` is then told (interval
    ``i``, from recorded velocity ``i`` to ``i + 1``) and it is tabulated once more. ``pull_power``: the profile
    is drawn toward ``residual_fn``'s residual by ``1 - |1 - 2w|^p`` instead of the bump (recorded in the table).
    """
    valid_pull(pull_power)
    banks = {b.object: b for b in banks}
    if not banks:
        raise CheckpointError("no banks to tabulate")
    say = progress or (lambda message: None)
    intervals = {}
    for obj, bank in banks.items():
        intervals[obj] = [_tabulate(bank, i, residual_fn, tolerance, on_rough, pull_power)
                          for i in range(len(bank) - 1)]
        say(f"{obj}: {len(intervals[obj])} intervals, {sum(len(iv.w) for iv in intervals[obj])} nodes")
    return VelocityTable.of(banks, intervals, interpolator=interpolator, source=source, dataset=dataset,
                            tolerance=tolerance, **({"pull": pull_power} if pull_power != 2 else {}))


def _tabulate(bank, i: int, residual_fn: ResidualFn, tolerance: float, on_rough, pull_power: int) -> Interval:
    try:
        return tabulate_interval(bank[i], bank[i + 1], residual_fn, tolerance, obj=bank.object, pull_power=pull_power)
    except CheckpointError:
        if on_rough is None:
            raise
    on_rough(bank.object, i)
    return tabulate_interval(bank[i], bank[i + 1], residual_fn, tolerance, obj=bank.object, pull_power=pull_power)


def _position(f: Fraction) -> float:
    return 0.5 - 0.5 * math.cos(math.pi * float(f))


def _nodes(degree: int) -> list[Fraction]:
    return [Fraction(j, degree) for j in range(degree + 1)]


def _ends_from_interior(degree: int, rows: list[np.ndarray]) -> list[np.ndarray]:
    """``rows`` with the two end rows replaced by the polynomial through the interior nodes (degree - 2), so that
    the profile ``linear + bump * s * r`` is the polynomial of degree ``degree`` through the profile at every node.
    For a method with no residual of its own at the neighbours (a physics model: ``r`` is 0/0 there)."""
    if degree < 2:
        zero = np.zeros_like(rows[0])
        return [zero, zero]
    inner = Interval(np.array([_position(f) for f in _nodes(degree)[1:-1]]), np.stack(rows[1:-1]))
    return [inner.at(0.0), *rows[1:-1], inner.at(1.0)]


def tabulate_interval(lo: Profile, hi: Profile, residual_fn: ResidualFn, tolerance: float, *, obj: str,
                      max_degree: int = _MAX_DEGREE, probes: int = 4, pull_power: int = 2) -> Interval:
    """The residual of one interval between neighbours ``lo`` and ``hi`` on Chebyshev-Lobatto nodes, the degree
    doubled until the polynomial misses ``residual_fn`` by at most ``tolerance`` at the nodes of ``probes`` times
    the degree (weighted by the pull, the bump for ``pull_power`` 2, relative to the neighbours' larger peak). With
    ``probes=2`` every probe is a node of the next degree: no evaluation is wasted (for a costly method, such as an
    ODE).

    A ``residual_fn`` may answer NaN at ``w`` = 0 and 1 (it has no value of its own there): the end rows are then
    those of the polynomial through the interior nodes (:func:`_ends_from_interior`).
    """
    n_samples = lo.samples.shape[-1]
    known: dict[Fraction, np.ndarray] = {}  # node j of degree d is the fraction j/d: nested degrees share nodes

    def fill(fracs: list[Fraction]) -> None:
        todo = [f for f in fracs if f not in known]
        if todo:
            ws = np.array([_position(f) for f in todo])
            v = lo.velocity + ws * (hi.velocity - lo.velocity)
            n = len(todo)
            r = residual_fn(np.repeat(lo.samples[None], n, 0), np.repeat(hi.samples[None], n, 0),
                            np.full(n, lo.velocity), np.full(n, hi.velocity), v, obj)
            known.update(zip(todo, np.asarray(r, dtype=np.float64).reshape(n, n_samples)))

    degree = 1
    while True:
        fill(_nodes(probes * degree))
        rows = [known[f] for f in _nodes(degree)]
        if not (np.all(np.isfinite(rows[0])) and np.all(np.isfinite(rows[-1]))):
            rows = _ends_from_interior(degree, rows)
        iv = Interval(np.array([_position(f) for f in _nodes(degree)]), np.stack(rows))
        checks = [f for f in _nodes(probes * degree) if f not in set(_nodes(degree))]
        err = max(float(np.max(pull(_position(f), pull_power) * np.abs(known[f] - iv.at(_position(f)))))
                  for f in checks)
        if err <= tolerance:
            return iv
        if 2 * degree > max_degree:
            raise CheckpointError(f"{obj}: the residual between {lo.velocity:g} and {hi.velocity:g} m/s is not "
                                  f"smooth enough to tabulate within {tolerance:g} (still {err:.2g} with "
                                  f"{degree + 1} nodes)")
        degree *= 2


class TableServed(Interpolator):
    """An interpolator answered from its :class:`VelocityTable` (``self.table``) when it has one: its answers are
    blends of the neighbours and the table's residual nodes, which a pipeline shapes once."""

    table: VelocityTable | None = None

    def blend(self, lower: Profile, upper: Profile, velocity: float) -> Blend | None:
        return None if self.table is None else self.table.blend(lower, upper, velocity)

    def atoms(self, bank) -> tuple[Term, ...]:
        return () if self.table is None else self.table.atoms(bank)


__all__ = ["VelocityTable", "Interval", "TableServed", "neighbours", "build_table", "tabulate_interval",
           "bank_digest", "shared_tables", "DEFAULT_TOLERANCE"]
