"""`hapticfx bench interpolators`: the paper's protocol (Tables 2, 3), cross-validation, run time, cache, continuity."""

from __future__ import annotations

import json
import math
import statistics
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from hapticfx.data.bank import ProfileBank
from hapticfx.data.dataset import open_dataset
from hapticfx.errors import DatasetError, EffectError
from hapticfx.interfaces import Profile
from hapticfx.registry import get_registry

from .config import ARCHS, MODEL_DEFAULTS, TRAINING_DEFAULTS, _merge
from .run import dataset_triples

PAPER_TRAIN = [2.80, 3.13, 3.43, 4.85, 5.05]
PAPER_TEST = [3.96, 4.43]
NEAR = 1e-6          # continuity probe distance from a recorded velocity, m/s
RANGE = np.linspace(0.0, 20.0, 81)


@dataclass
class BenchOptions:
    """What `hapticfx bench interpolators` runs (see its --help)."""

    dataset: str = "builtin:helmet-drops"
    reducer: str = "max-min"
    methods: list[str] = field(default_factory=lambda: ["linear", *ARCHS])
    train: list[float] | None = None
    test: list[float] | None = None
    epochs: int = 100
    cv: bool = True
    cv_methods: list[str] | None = None
    cv_epochs: int = 30
    cached: list[str] = field(default_factory=lambda: ["convbilstm"])
    grid_step: float = 0.01
    repeats: int = 50
    seed: int = 0
    config: Path | None = None
    out: Path = Path("bench-interpolators")
    threads: int = 1


def _rmse(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def _match(v: float, recorded: np.ndarray) -> float | None:
    hit = np.flatnonzero(np.isclose(recorded, v, rtol=0, atol=5e-4))
    return float(recorded[hit[0]]) if hit.size else None


def choose_velocities(banks: dict[str, ProfileBank], train, test) -> tuple[list[float], list[float]]:
    """Train and test velocities: given, else the paper's when recorded, else a split of the interior ones."""
    recorded = sorted(set.intersection(*(set(map(float, b.velocities)) for b in banks.values())))
    rec = np.array(recorded)
    interior = recorded[1:-1]
    if len(interior) < 3:
        raise DatasetError(f"the benchmark needs at least 5 velocities recorded for every object; common: {recorded}")
    if test is None:
        paper = [_match(v, rec) for v in PAPER_TEST]
        test = paper if all(p is not None for p in paper) else sorted({interior[len(interior) // 3],
                                                                       interior[(2 * len(interior)) // 3]})
    if train is None:
        paper = [_match(v, rec) for v in PAPER_TRAIN]
        if all(p is not None for p in paper) and not set(paper) & set(test):
            train = paper
        else:
            train = [v for v in interior if v not in test]
    train = [_snap(v, rec, "--train") for v in train]
    test = [_snap(v, rec, "--test") for v in test]
    for v in test:
        if v in train:
            raise EffectError(f"--test velocity {v} is also a training velocity")
        if v not in interior:
            raise EffectError(f"--test velocity {v} needs a recorded velocity on each side; interior: {interior}")
    return train, test


def _snap(v: float, rec: np.ndarray, opt: str) -> float:
    hit = _match(v, rec)
    if hit is None:
        raise EffectError(f"{opt} velocity {v} m/s is not recorded for every object; recorded: "
                          f"{', '.join(f'{x:g}' for x in rec)}")
    return hit


def _overrides(opts: BenchOptions) -> dict:
    """``--config``: method (or a new row name with ``interpolator:``) -> {model, training} overrides."""
    if opts.config is None:
        return {}
    import yaml

    try:
        data = yaml.safe_load(Path(opts.config).read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise EffectError(f"cannot read bench overrides: {exc}", source=str(opts.config)) from exc
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise EffectError("expected a mapping: method -> {interpolator, model, training}", source=str(opts.config))
    return data


def _arch(method: str, opts: BenchOptions) -> str:
    """The interpolator a benchmark row trains (a row may be a named variant from ``--config``)."""
    return _overrides(opts).get(method, {}).get("interpolator", method)


def _method_config(method: str, opts: BenchOptions, epochs: int) -> tuple[dict, dict]:
    over = _overrides(opts).get(method, {})
    src = str(opts.config or "<bench>")
    model = _merge(MODEL_DEFAULTS[_arch(method, opts)], over.get("model"), src, f"{method}.model")
    training = _merge(TRAINING_DEFAULTS, {"epochs": epochs, "seed": opts.seed, "threads": opts.threads,
                                          **(over.get("training") or {})}, src, f"{method}.training")
    return model, training


def _train(method: str, dataset, opts: BenchOptions, objects, *, train, holdout, epochs: int, label: str):
    """A trained interpolator object for ``method`` (linear: nothing to train) and its training seconds."""
    from .training import train_network

    arch = _arch(method, opts)
    interp = get_registry().create("interpolator", arch)
    if arch == "linear":
        return interp, 0.0, 0
    model, training = _method_config(method, opts, epochs)
    data, targets = dataset_triples(dataset, opts.reducer, objects, train=train, holdout=holdout)
    interp.net, interp.meta = train_network(
        arch, model, training, data, label=label,
        dataset_meta={"name": dataset.name, "reducer": opts.reducer, "objects": list(objects), "targets": targets,
                      "holdout": list(holdout)})
    return interp, interp.meta["training"]["train_time_s"], interp.meta["parameters"]


def _latency(fn: Callable[[], object], repeats: int) -> dict:
    for _ in range(3):
        fn()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    ts.sort()
    return {"median_ms": 1e3 * statistics.median(ts), "p99_ms": 1e3 * ts[min(len(ts) - 1, math.ceil(0.99 * len(ts)) - 1)]}


def _test_split(banks, v):
    """Neighbours of ``v`` in each bank without ``v``, and the measured profile."""
    out = {}
    for obj, bank in banks.items():
        lo, hi = bank.without(v).neighbours(v)
        out[obj] = (lo, hi, bank.profiles[bank.index_of(v)])
    return out


def _continuity_and_range(method: str, interp, dataset_ref: str, opts: BenchOptions, objects, tmp: Path) -> dict:
    """Through the core data-driven model: jumps at recorded velocities (+-1e-6) and finiteness over 0..20 m/s."""
    from hapticfx.models.datadriven import DataDrivenModel
    from hapticfx.params import BuildContext

    options = {}
    if method != "linear":
        path = tmp / method / "model.safetensors"
        interp.save(path)
        options["weights"] = str(path)
    res = {}
    for cached in [False]:
        if method != "linear":
            options = {**options, "cache": False}
        model = DataDrivenModel(DataDrivenModel.Params(dataset=dataset_ref, reducer=opts.reducer, interpolator=interp.name,
                                                       interpolator_options=dict(options)), BuildContext())
        worst = {"jump_g": 0.0, "relative": 0.0, "object": None, "velocity": None}
        finite = True
        for obj in objects:
            bank = model.bank(obj)
            for r in bank.velocities[1:-1]:
                ref = bank.profiles[bank.index_of(r)]
                for side in (-NEAR, NEAR):
                    j = _rmse(model.profile(obj, float(r) + side), ref)
                    if j > worst["jump_g"]:
                        worst = {"jump_g": j, "relative": j / max(_rmse(ref, 0 * ref), 1e-12), "object": obj,
                                 "velocity": float(r)}
            for v in RANGE:
                finite &= bool(np.all(np.isfinite(model.profile(obj, float(v)))))
        res["cached" if cached else "direct"] = {**worst, "finite_0_20": finite, "outside": model.params.outside}
    return res


def run_bench(opts: BenchOptions, *, echo: Callable[[str], None] = print) -> dict:
    """Run the benchmark, write tables (markdown + JSON) and PNGs to ``opts.out``; returns the results."""
    import torch

    torch.set_num_threads(opts.threads)
    unknown = [m for m in opts.methods + (opts.cv_methods or []) if _arch(m, opts) not in ("linear", *ARCHS)]
    if unknown:
        raise EffectError(f"unknown method(s) {', '.join(unknown)}; available: linear, {', '.join(ARCHS)} "
                          "and rows named in --config with an `interpolator:` key")
    methods = ["linear"] + [m for m in opts.methods if m != "linear"]
    dataset = open_dataset(opts.dataset)
    objects = dataset.objects
    banks = {o: dataset.bank(o, opts.reducer) for o in objects}
    train, test = choose_velocities(banks, opts.train, opts.test)
    out = Path(opts.out)
    out.mkdir(parents=True, exist_ok=True)
    echo(f"dataset {dataset.name} ({opts.reducer}), objects {', '.join(objects)}")
    echo(f"train targets {train} m/s, test {test} m/s; up to {opts.epochs} epochs, seed {opts.seed}, "
         f"{opts.threads} threads")
    results: dict = {"dataset": dataset.name, "reducer": opts.reducer, "train": train, "test": test,
                     "epochs": opts.epochs, "cv_epochs": opts.cv_epochs, "seed": opts.seed, "methods": {},
                     "torch_threads": opts.threads}
    preds: dict = {}
    with tempfile.TemporaryDirectory() as tmpdir:
        for method in methods:
            interp, train_s, params = _train(method, dataset, opts, objects, train=train, holdout=test,
                                             epochs=opts.epochs, label=f"{method} (paper split)")
            torch.set_num_threads(opts.threads)  # training may have used training.threads
            r = {"train_s": train_s, "parameters": params, "rmse": {}}
            if method != "linear":
                r["epochs_run"] = interp.meta["training"]["epochs_run"]
                r["best_epoch"] = interp.meta["training"]["best_epoch"]
            for v in test:
                for obj, (lo, hi, truth) in _test_split(banks, v).items():
                    p = interp.interpolate(lo, hi, v)
                    r["rmse"][(obj, v)] = _rmse(p, truth)
                    preds[(method, obj, v)] = p
            r["avg_rmse"] = float(np.mean(list(r["rmse"].values())))
            lo, hi, _ = _test_split(banks, test[0])[objects[0]]
            r["latency"] = _latency(lambda: interp.interpolate(lo, hi, test[0]), opts.repeats)
            echo(f"{method}: continuity and range checks through the data-driven model")
            r["continuity"] = _continuity_and_range(method, interp, opts.dataset, opts, objects, Path(tmpdir))
            echo(f"{method}: average test RMSE {r['avg_rmse']:.4f} g, latency median {r['latency']['median_ms']:.3f} ms")
            results["methods"][method] = r
    if opts.cv:
        results["cv"] = _cross_validate(dataset, banks, objects, opts, echo)
    _write(results, preds, banks, out, echo)
    return results


def _cross_validate(dataset, banks, objects, opts: BenchOptions, echo) -> dict:
    """Leave one interior velocity out: train on the rest (it is removed from the bank), test at it."""
    recorded = sorted(set.intersection(*(set(map(float, b.velocities)) for b in banks.values())))
    folds = recorded[1:-1]
    methods = ["linear"] + [m for m in (opts.cv_methods or opts.methods) if m != "linear"]
    cv = {}
    for method in methods:
        per_fold = []
        for k, v in enumerate(folds):
            interp, _, _ = _train(method, dataset, opts, objects, train=None, holdout=[v], epochs=opts.cv_epochs,
                                  label=f"{method} CV {k + 1}/{len(folds)} (leave {v:g} out)")
            errs = [_rmse(interp.interpolate(lo, hi, v), truth) for lo, hi, truth in _test_split(banks, v).values()]
            per_fold.append(float(np.mean(errs)))
        cv[method] = {"folds": dict(zip(folds, per_fold)), "mean": float(np.mean(per_fold)),
                      "std": float(np.std(per_fold, ddof=1)) if len(per_fold) > 1 else 0.0}
        echo(f"{method}: cross-validated RMSE {cv[method]['mean']:.4f} ± {cv[method]['std']:.4f} g")
    return cv


def _write(results: dict, preds: dict, banks, out: Path, echo) -> None:
    from .report import figures, tables

    md = tables(results)
    (out / "tables.md").write_text(md)
    (out / "results.json").write_text(json.dumps(_jsonable(results), indent=1) + "\n")
    np.savez_compressed(out / "predictions.npz", **{f"{m}@{o}@{v}": p for (m, o, v), p in preds.items()})
    figures(results, preds, banks, out)
    echo(md)
    echo(f"wrote {out / 'tables.md'}, {out / 'results.json'}, {out / 'predictions.npz'}, "
         f"{out / 'error_vs_latency.png'}, {out / 'fig8.png'}")


def _jsonable(x):
    if isinstance(x, dict):
        return {(f"{k[0]}@{k[1]}" if isinstance(k, tuple) else str(k)): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x
