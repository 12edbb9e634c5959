"""Running interpolators over evaluation rounds: fit on the training data, predict the held-out folds.

Every method sees the same rounds. Per fold it is scored against the held-out
representative, against every recorded drop at that velocity and against their mean,
in RMSE, log-spectral distance and the perceptual ST-SIM and SPQI (against every drop;
:mod:`hapticfx.processing.perceptual`), beside the floors those drops set
(:func:`hapticfx.evaluation.measures.floors`). A method that can
serve a velocity table (``tabulate``) is also served from one, and the table's
answer is compared with the method's own.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from .. import __version__
from ..data.dataset import Dataset
from ..data.training import recorded_drops, training_data
from ..errors import EffectError, HapticfxError
from ..registry import get_registry
from ..timing import measure
from ..processing import likeness, perceptual
from . import measures
from .folds import rounds_for


@dataclass(frozen=True)
class Method:
    """One row of the evaluation: a registered interpolator, its options and its fit options."""

    row: str
    interpolator: str
    options: dict = field(default_factory=dict)
    fit: dict = field(default_factory=dict)


def methods_from(names: list[str], config: Path | None = None) -> list[Method]:
    """Rows for ``names``; ``config`` (YAML) maps a row name to ``{interpolator, options, model, training}``.

    A row named like an interpolator overrides its settings; a new name with ``interpolator:`` adds a
    variant (for example the shipped ConvBiLSTM's sizes). ``linear`` always comes first: the baseline.
    """
    rows = {}
    if config is not None:
        try:
            rows = yaml.safe_load(Path(config).read_text()) or {}
        except (OSError, yaml.YAMLError) as exc:
            raise EffectError(f"cannot read: {exc}", source=str(config)) from exc
        if not isinstance(rows, dict) or not all(isinstance(v, dict) for v in rows.values()):
            raise EffectError("expected a mapping: row -> {interpolator, options, model, training}", source=str(config))
    known = set(get_registry().names("interpolator"))
    out = []
    for name in ["linear"] + [n for n in names if n != "linear"]:
        row = rows.get(name, {})
        unknown = sorted(set(row) - {"interpolator", "options", "model", "training"})
        if unknown:
            raise EffectError(f"unknown key(s) {', '.join(unknown)}; allowed: interpolator, options, model, training",
                              source=str(config), key=name)
        interp = row.get("interpolator", name)
        if interp not in known:
            raise EffectError(f"unknown method {name!r}: no interpolator {interp!r}; installed: "
                              f"{', '.join(sorted(known))} (or rows named in --config with an `interpolator:` key)")
        fit = {k: row[k] for k in ("model", "training") if k in row}
        out.append(Method(name, interp, dict(row.get("options") or {}), fit))
    return out


def _fold_truth(dataset: Dataset, obj: str, reducer: str, velocity: float, drops_cache: dict):
    """The representative at ``velocity``, every drop recorded there (or None) and its representative's index."""
    bank = dataset.bank(obj, reducer)
    i = bank.index_of(velocity)
    if obj not in drops_cache:
        drops_cache[obj] = recorded_drops(dataset, obj, reducer)
    found = drops_cache[obj]
    if found is None:
        return bank.profiles[i], None, None
    velocities, drops = found
    j = int(np.flatnonzero(np.isclose(velocities, velocity, rtol=0, atol=1e-9))[0])
    rep = int(dataset.representatives(obj)["chosen"][j])
    return bank.profiles[i], drops[j], rep


def _scores(pred, truth, drops, rate_hz: float) -> dict:
    out = {"rmse": float(likeness.rmse(pred, truth)),
           "lsd_db": float(likeness.log_spectral_distance(pred, truth, rate_hz=rate_hz)),
           "peak_db": float(likeness.peak_error_db(pred, truth))}
    if drops is not None:
        out["rmse_drops"] = float(np.mean(likeness.rmse(pred, drops)))
        out["rmse_mean"] = float(likeness.rmse(pred, drops.mean(axis=0)))
        out["lsd_drops_db"] = float(np.mean(likeness.log_spectral_distance(pred, drops, rate_hz=rate_hz)))
    out.update(perceptual.scores(pred, truth[None] if drops is None else drops, rate_hz=rate_hz))
    return out


def run_evaluation(dataset: Dataset, reducer: str, methods: list[Method], *, protocol: str = "lovo",
                   repeats: int = 50, max_rounds: int | None = None, previous: dict | None = None,
                   previous_source: str | None = None, on_round: Callable[[dict], None] | None = None,
                   echo: Callable[[str], None] = print, jobs: int = 1) -> dict:
    """Fit every method on every round and score it on the held-out folds; returns plain data (JSON-able).

    ``max_rounds``: run only that many rounds, evenly spread over the protocol's (the result says how many).
    ``previous``: the results of an earlier run of the same dataset, reducer, protocol and rows; the rounds it
    finished are kept, not run again (:func:`kept_rounds`; ``previous_source``, the file it came from, is what
    its errors name). ``on_round``: called with the results so far after
    each round, so that a long run can be saved as it goes. ``jobs``: rounds fitted side by side in that many
    processes (joblib; 0: one per core); the results are those of a serial run, except the timings, which are
    then taken beside the other processes.
    """
    banks = {o: dataset.bank(o, reducer) for o in dataset.objects}
    rounds = rounds_for(protocol, banks)
    if max_rounds is not None and max_rounds < len(rounds):
        rounds = [rounds[int(i)] for i in np.unique(np.linspace(0, len(rounds) - 1, max_rounds).round())]
    kept = kept_rounds(previous, dataset.name, reducer, protocol, methods, rounds, source=previous_source) \
        if previous else {}
    rate = dataset.rate_hz
    drops_cache: dict = {}
    floors: dict[int, list[dict]] = {}
    for k, rnd in enumerate(rounds):
        floors[k] = []
        for f in rnd.folds:
            _, drops, rep = _fold_truth(dataset, f.object, reducer, f.velocity, drops_cache)
            floor = {**measures.floors(drops, rep, rate_hz=rate), **measures.drop_pairs(drops, rate_hz=rate)} \
                if drops is not None else {}
            floors[k].append({"object": f.object, "velocity": f.velocity, "round": k, **floor})
    rows = {m.row: {"interpolator": m.interpolator, **_settings(m), "fits": [], "folds": [], "error": None}
            for m in methods}
    done: list[int] = []
    to_fit = [k for k in range(len(rounds)) if k not in kept]
    workers = max(1, min(jobs or os.cpu_count() or 1, len(to_fit)))

    def finished(k: int) -> None:
        done.append(k)
        if on_round is not None:
            on_round(_results(dataset, reducer, protocol, floors, done, len(rounds), rows, workers))

    def held(k: int) -> str:
        return f"[{k + 1}/{len(rounds)}] {rounds[k].name}: " + ("kept from the earlier run, " if k in kept else "") \
            + "hold out " + ", ".join(f"{f.object} {f.velocity:g}" for f in rounds[k].folds)

    for k, j in kept.items():
        echo(held(k))
        _keep_round(previous, j, k, floors[k], rows, middle=k == len(rounds) // 2, source=previous_source)
        finished(k)
    untimed = {m.row for m in methods if "latency_ms" not in rows[m.row]}
    if workers == 1:
        for k in to_fit:
            echo(held(k))
            skip = {name for name, row in rows.items() if row["error"]}
            _merge(rows, _fit_round(dataset, reducer, methods, rounds[k], k, len(rounds), skip=skip,
                                    timed=untimed if k == to_fit[0] else set(), repeats=repeats, echo=echo)[1])
            finished(k)
    else:
        from joblib import Parallel, delayed

        for k in to_fit:
            echo(held(k))
        echo(f"{len(to_fit)} rounds in {workers} processes")
        calls = (delayed(_fit_round)(dataset.path, reducer, methods, rounds[k], k, len(rounds),
                                     timed=untimed if k == to_fit[0] else set(), repeats=repeats)
                 for k in to_fit)
        for k, fitted in Parallel(n_jobs=workers, return_as="generator_unordered")(calls):
            _merge(rows, fitted)
            finished(k)
            echo(f"[{k + 1}/{len(rounds)}] done; {len(done)} of {len(rounds)} rounds finished")
    return _results(dataset, reducer, protocol, floors, done, len(rounds), rows, workers)


def _fit_round(dataset: Dataset | Path, reducer: str, methods: list[Method], rnd, k: int, n_rounds: int, *,
               skip: set = frozenset(), timed: set, repeats: int,
               echo: Callable[[str], None] | None = None) -> tuple[int, dict]:
    """Round ``k``: fit every method (but those in ``skip``) on its training data and score its folds.

    Returns ``(k, {row: {"fits", "folds", "error", and "latency_ms"... where timed}})``. ``dataset`` is a path
    in a worker process, which then writes its lines on standard error, tagged with the round.
    """
    if not isinstance(dataset, Dataset):
        from ..data.dataset import open_dataset
        from ..progress import lines_only, say

        lines_only()  # several processes share one terminal: no line redrawn in place
        dataset = open_dataset(dataset)
        echo = lambda message: say(f"[{k + 1}/{n_rounds}] {message.strip()}")  # noqa: E731
    rate = dataset.rate_hz
    drops_cache: dict = {}
    truths = {f: _fold_truth(dataset, f.object, reducer, f.velocity, drops_cache)[:2] for f in rnd.folds}
    data = training_data(dataset, reducer, holdout=rnd.holdout, targets=rnd.targets)
    out = {}
    for m in methods:
        if m.row in skip:
            continue
        row = out[m.row] = {"fits": [], "folds": [], "error": None}
        echo(f"  {m.row}: fitting")
        try:
            _run_method(m, row, data, rnd, k, truths, rate, repeats if m.row in timed else 0,
                        k == n_rounds // 2, echo)
        except HapticfxError as exc:
            row["error"] = str(exc)
            echo(f"  {m.row}: skipped: {exc}")
    return k, out


def _merge(rows: dict, fitted: dict) -> None:
    """Add one round's fits and scores (:func:`_fit_round`) to ``rows``; a row keeps its first error."""
    for name, part in fitted.items():
        row = rows[name]
        row["fits"] += part["fits"]
        row["folds"] += part["folds"]
        row["error"] = row["error"] or part["error"]
        for key in ("latency_ms", "table_latency_ms"):
            if key in part:
                row[key] = part[key]
        if "predictions" in part:
            row.setdefault("predictions", {}).update(part["predictions"])


def _results(dataset: Dataset, reducer: str, protocol: str, floors: dict, done: list[int], planned: int,
             rows: dict, processes: int) -> dict:
    """The results of the rounds in ``done``, in round order (the order a serial run adds them in);
    ``processes``: how many fitted rounds side by side (their times were taken beside each other)."""
    finished = set(done)
    folds = [f for k in sorted(finished) for f in floors[k]]
    out = {}
    for name, row in rows.items():
        out[name] = {**row, "fits": sorted(row["fits"], key=lambda x: x["round"]),
                     "folds": sorted(row["folds"], key=lambda x: x["round"])}
    return {"dataset": dataset.name, "reducer": reducer, "protocol": protocol, "rate_hz": dataset.rate_hz,
            "hapticfx": __version__, "rounds": len(finished), "rounds_planned": planned, "processes": processes,
            "folds": folds, "methods": out}


def _settings(m: Method) -> dict:
    """A row's options and fit settings as they read back from JSON (what a resumed run compares)."""
    return json.loads(json.dumps({"options": m.options, "fit": m.fit}, default=str))


def kept_rounds(previous: dict, dataset: str, reducer: str, protocol: str, methods: list[Method],
                rounds: list, *, source: str | None = None) -> dict[int, int]:
    """Which of ``rounds`` an earlier run (``previous``) finished for every row: round index -> its index there.

    The earlier run must be of the same dataset, reducer and fold protocol, by this version of hapticfx, with
    the same rows and settings (an error says what differs); its rounds are matched by their held-out folds.
    The data is checked as each kept round is taken (:func:`_keep_round`)."""
    if "hapticfx" not in previous:
        raise EffectError("the earlier run was written by a hapticfx that cannot resume it; run without resuming, "
                          "or into another folder", source=source)
    want = {"dataset": dataset, "reducer": reducer, "protocol": protocol, "hapticfx": __version__}
    for key, value in want.items():
        if previous.get(key) != value:
            raise EffectError(f"the earlier run has {key} {previous.get(key)!r}, this one {value!r}; "
                              "run without resuming, or into another folder", source=source)
    rows = {m.row: {"interpolator": m.interpolator, **_settings(m)} for m in methods}
    before = {name: {k: r.get(k) for k in ("interpolator", "options", "fit")}
              for name, r in previous.get("methods", {}).items()}
    if before != rows:
        differ = sorted(set(rows) ^ set(before) | {n for n in set(rows) & set(before) if rows[n] != before[n]})
        raise EffectError(f"the earlier run's rows differ from these in: {', '.join(differ)}; "
                          "run with the same --methods and --config, or into another folder", source=source)
    held = {}
    for f in previous["folds"]:
        held.setdefault(f.get("round"), set()).add((f.get("object"), f.get("velocity")))
    out = {}
    for k, rnd in enumerate(rounds):
        want_folds = {(f.object, f.velocity) for f in rnd.folds}
        j = next((j for j, got in held.items() if got == want_folds), None)
        if j is not None and all(not r.get("error") and any(x.get("round") == j for x in r.get("fits", []))
                                 for r in previous["methods"].values()):
            out[k] = j
    return out


def _keep_round(previous: dict, j: int, k: int, floors: list[dict], rows: dict, *, middle: bool,
                source: str | None) -> None:
    """Copy round ``j`` of ``previous`` into ``rows`` as round ``k``, once its folds' floors (just computed from
    the data) are the ones it recorded."""
    before = {(f["object"], f["velocity"]): f for f in previous["folds"] if f["round"] == j}
    for f in floors:
        old = before[(f["object"], f["velocity"])]
        if any(not np.isclose(old.get(key, np.nan), value, rtol=1e-9, atol=0, equal_nan=True)
               for key, value in f.items() if key not in ("object", "velocity", "round")):
            raise EffectError(f"the drops of {f['object']} at {f['velocity']:g} m/s are not those of the earlier "
                              "run; run without resuming, or into another folder", source=source)
    for name, row in rows.items():
        old = previous["methods"][name]
        row["fits"] += [{**x, "round": k} for x in old["fits"] if x.get("round") == j]
        row["folds"] += [{**e, "round": k} for e in old["folds"] if (e["object"], e["velocity"]) in before]
        for key in ("latency_ms", "table_latency_ms"):
            if key in old and "latency_ms" not in row:
                row[key] = old[key]
        if middle:
            mine = {f"{o}@{v:g}" for o, v in before}
            row["predictions"] = {key: p for key, p in old.get("predictions", {}).items() if key in mine}


def _run_method(m: Method, row: dict, data, rnd, k: int, truths: dict, rate: float, repeats: int, keep: bool,
                echo) -> None:
    interp = get_registry().create("interpolator", m.interpolator, **m.options)
    t0 = time.perf_counter()
    summary = interp.fit(data, **m.fit, label=f"{m.row}, round {k + 1}", progress=True)
    fit_s = time.perf_counter() - t0
    for bank in data.banks.values():
        interp.prepare(bank)
    table = interp.tabulate(data) if hasattr(interp, "tabulate") else None
    if table is not None:
        for bank in data.banks.values():
            table.attach(bank, rebuild="(evaluation)")
    row["fits"].append({"round": k, "fit_s": fit_s,
                        **{key: v for key, v in summary.items() if isinstance(v, (int, float, str))}})
    for f in rnd.folds:
        lo, hi = data.banks[f.object].neighbours(f.velocity)
        pred = interp.interpolate(lo, hi, f.velocity)
        truth, drops = truths[f]
        entry = {"object": f.object, "velocity": f.velocity, "round": k, **_scores(pred, truth, drops, rate)}
        if keep:
            row.setdefault("predictions", {})[f"{f.object}@{f.velocity:g}"] = pred.tolist()
        if table is not None:
            served = table.lookup(lo, hi, f.velocity)
            entry["table_vs_direct"] = float(np.max(np.abs(served - pred)) / max(np.max(np.abs(pred)), 1e-12))
        row["folds"].append(entry)
    if repeats:
        f = rnd.folds[0]
        lo, hi = data.banks[f.object].neighbours(f.velocity)
        t = measure(lambda: interp.interpolate(lo, hi, f.velocity), repeat=repeats, warmup=3)
        row["latency_ms"] = {"median": 1e3 * t.median, "p99": 1e3 * t.p99}
        if table is not None:
            t = measure(lambda: table.lookup(lo, hi, f.velocity), repeat=max(repeats, 200), warmup=3)
            row["table_latency_ms"] = {"median": 1e3 * t.median, "p99": 1e3 * t.p99}
    mean = np.mean([e["rmse"] for e in row["folds"][-len(rnd.folds):]])
    echo(f"  {m.row}: fitted in {fit_s:.1f} s, RMSE {mean:.4f} g on this round")
