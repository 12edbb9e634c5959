"""``hapticfx bench interpolators``: every method on the same held-out velocities, against the floors."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Optional

import typer

from ..atomic import atomic_path
from ..errors import EffectError
from ..progress import say


def interpolators(
    dataset: str = typer.Option("builtin:helmet-drops", "--dataset", "-d", metavar="DATASET",
                                help="Dataset path, builtin:NAME or "
                                "heldout:NAME (a held-out set, simulated on first use; see "
                                "hapticfx/datasets/heldout/README.md)."),
    reducer: str = typer.Option("max-min", "--reducer", metavar="NAME", help="Which bank of the dataset."),
    methods: str = typer.Option("linear,ensemble,ensemble-warp", "--methods", metavar="NAME,...",
                                help="Comma-separated rows: interpolator names, or rows named in --config. linear "
                                "is always included: every ratio is against it. Default: the shipped effects' "
                                "ensemble-warp beside ensemble."),
    protocol: str = typer.Option("lovo", "--protocol", metavar="lovo|looo|paper|generalisation",
                                 help="lovo: leave each interior velocity of every object out "
                                 "in turn (any dataset); looo: leave each object out in turn (no training target "
                                 "from it; its interior velocities predicted from its neighbours); paper: the "
                                 "paper's split (train 2.80, 3.13, 3.43, 4.85, 5.05; test 3.96, 4.43 m/s); "
                                 "generalisation: the same rows on builtin:helmet-drops (lovo), every held-out set "
                                 "(lovo) and builtin:helmet-drops (looo), one table per dataset with issue 26's "
                                 "criteria as pass/fail (not with --dataset)."),
    config: Optional[Path] = typer.Option(None, "--config", metavar="YAML",
                                          help="YAML: row -> {interpolator, options, model, "
                                          "training} (e.g. network sizes; see docs/neural.md)."),
    epochs: Optional[int] = typer.Option(None, "--epochs", metavar="COUNT", min=1,
                                         help="Maximum training epochs of learned rows "
                                         "(default: their configuration's)."),
    seed: int = typer.Option(0, "--seed", metavar="SEED",
                             help="Training seed of learned rows and the bootstrap's seed."),
    repeats: int = typer.Option(50, "--repeats", metavar="COUNT", min=5,
                                help="Timed predictions per method (first round)."),
    max_rounds: Optional[int] = typer.Option(None, "--max-rounds", metavar="COUNT", min=1,
                                             help="Run at most this many rounds per "
                                             "dataset, evenly spread (tables say how many folds ran)."),
    jobs: int = typer.Option(1, "--jobs", "-j", metavar="COUNT", min=0, max=256,
                             help="Rounds fitted side by side in this many processes (joblib, loky); 0: one per "
                             "core. Each network trains on its own configuration's torch threads (one by "
                             "default), so a round of networks is best given a core of its own. Any value gives "
                             "the same scores; run times are then taken beside the other processes."),
    out: Path = typer.Option(Path("bench-interpolators"), "--out", "-o", metavar="DIR", help="Directory for tables.md, "
                             "results.json and the PNGs (one sub-folder per dataset for generalisation). "
                             "results.json is rewritten after every round."),
    resume: bool = typer.Option(False, "--resume", help="Keep the rounds that the results.json already in --out "
                                "finished and run only the others (a stopped run loses only the round it was in). "
                                "The dataset, rows and settings must be the same, and so must the hapticfx version; "
                                "the drops are checked against the recorded floors."),
):
    """Score interpolators on held-out recorded velocities: RMSE against the representative, every drop and
    the drops' mean, log-spectral distance, peak error, ST-SIM and SPQI; paired ratios to linear and shares
    of the gap to the floors the recorded drops set, with bootstrap CIs; run time. Works on datasets whose
    objects have different velocities."""
    from ..evaluation import protocol as gen
    from ..evaluation.folds import PROTOCOLS
    from ..evaluation.runner import Method, methods_from

    if protocol not in (*PROTOCOLS, "generalisation"):
        raise EffectError(f"unknown protocol {protocol!r}; one of: {', '.join(PROTOCOLS)}, generalisation",
                          key="--protocol")
    names = [m.strip() for m in methods.split(",") if m.strip()]
    rows = methods_from(names, config)
    training = {k: v for k, v in (("epochs", epochs), ("seed", seed)) if v is not None}
    rows = [Method(r.row, r.interpolator, r.options,
                   {**r.fit, "training": {**training, **r.fit.get("training", {})}} if training else r.fit)
            for r in rows]
    if protocol != "generalisation":
        md = _run(dataset, protocol, reducer, rows, seed=seed, repeats=repeats, max_rounds=max_rounds, out=out,
                  resume=resume, jobs=jobs)[0]
        typer.echo(md)
        return
    if dataset != "builtin:helmet-drops":
        raise EffectError("--protocol generalisation runs its fixed list of datasets; drop --dataset")
    started = time.perf_counter()
    tables, runs = [], []
    for ref, fold_protocol in gen.DATASETS:
        sub = out / f"{ref.split(':')[-1]}-{fold_protocol}"
        _, results, summary = _run(ref, fold_protocol, reducer, rows, seed=seed, repeats=repeats,
                                   max_rounds=max_rounds, out=sub, resume=resume, jobs=jobs)
        runs.append((results, summary))
        tables.append(gen.table(results, summary))
        typer.echo(tables[-1])
    typer.echo(gen.combined(runs))
    text = (f"Rows: {', '.join(r.row for r in rows)}; reducer {reducer}; seed {seed}"
            + (f"; at most {max_rounds} rounds per dataset" if max_rounds else "; every round")
            + f"; {time.perf_counter() - started:.0f} s.\n\n" + "\n".join(tables) + "\n" + gen.combined(runs))
    (out / "protocol.md").write_text(text)
    say(f"wrote {out / 'protocol.md'} and one folder per dataset in {out}")


def _run(ref: str, protocol: str, reducer: str, rows, *, seed: int, repeats: int, max_rounds: int | None,
         out: Path, resume: bool = False, jobs: int = 1):
    """One dataset and fold protocol: run, summarise, write tables.md, results.json and the PNGs into ``out``."""
    from ..evaluation.heldout import open_with_bank
    from ..evaluation.report import figures, markdown, summarise
    from ..evaluation.runner import run_evaluation

    ds = open_with_bank(ref, reducer, progress=say)
    say(f"dataset {ds.name} ({reducer}), protocol {protocol}, methods {', '.join(r.row for r in rows)}")
    file = out / "results.json"
    previous = _earlier(file) if resume else None

    def save(results: dict) -> dict:  # the folder appears with the first result: a refused run leaves none
        summary = summarise(results, seed=seed)
        with atomic_path(file, make_parents=True) as tmp:
            tmp.write_text(json.dumps({"results": results, "summary": summary}, indent=1) + "\n")
        return summary

    results = run_evaluation(ds, reducer, rows, protocol=protocol, repeats=repeats, max_rounds=max_rounds,
                             previous=previous, previous_source=str(file), on_round=save, echo=say, jobs=jobs)
    summary = save(results)
    md = markdown(results, summary)
    (out / "tables.md").write_text(md)
    pngs = figures(results, summary, {o: ds.bank(o, reducer) for o in ds.objects}, out)
    say(f"wrote {out / 'tables.md'}, {out / 'results.json'}, " + ", ".join(map(str, pngs)))
    return md, results, summary


def _earlier(file: Path) -> dict | None:
    """The results of the run saved in ``file``, or None (and a line saying so) where there is none yet."""
    if not file.exists():
        say(f"{file}: no earlier run to resume; running every round")
        return None
    try:
        data = json.loads(file.read_text())
        results = data["results"]
        if not isinstance(results["folds"], list) or not isinstance(results["methods"], dict):
            raise TypeError("folds or methods of the wrong type")
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise EffectError(f"cannot resume from it ({type(exc).__name__}: {exc}); expected the results.json of "
                          "`hapticfx bench interpolators`", source=str(file)) from exc
    return results


def register(bench: typer.Typer) -> None:
    bench.command("interpolators")(interpolators)
