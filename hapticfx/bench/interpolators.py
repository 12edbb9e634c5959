"""``hapticfx bench interpolators``: every method on the same held-out velocities, against the floors."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from ..errors import EffectError
from ..progress import say


def interpolators(
    dataset: str = typer.Option("builtin:helmet-drops", "--dataset", "-d", help="Dataset path, builtin:NAME or heldout:NAME (a held-out set, simulated on first use; "
                           "see hapticfx/datasets/heldout/README.md)."),
    reducer: str = typer.Option("max-min", "--reducer", help="Which bank of the dataset."),
    methods: str = typer.Option("linear,ensemble", "--methods", help="Comma-separated rows: interpolator names, or "
                                "rows named in --config. linear is always included: every ratio is against it."),
    protocol: str = typer.Option("lovo", "--protocol", help="lovo: leave each interior velocity of every object out "
                                 "in turn (any dataset); looo: leave each object out in turn (no training target from it; "
                                 "its interior velocities predicted from its neighbours); paper: the paper's split (train 2.80, 3.13, 3.43, 4.85, "
                                 "5.05; test 3.96, 4.43 m/s)."),
    config: Optional[Path] = typer.Option(None, "--config", help="YAML: row -> {interpolator, options, model, "
                                          "training} (e.g. network sizes; see docs/neural.md)."),
    epochs: Optional[int] = typer.Option(None, "--epochs", min=1, help="Maximum training epochs of learned rows "
                                         "(default: their configuration's)."),
    seed: int = typer.Option(0, "--seed", help="Training seed of learned rows and the bootstrap's seed."),
    repeats: int = typer.Option(50, "--repeats", min=5, help="Timed predictions per method (first round)."),
    out: Path = typer.Option(Path("bench-interpolators"), "--out", "-o", help="Directory for tables.md, "
                             "results.json and the PNGs."),
):
    """Score interpolators on held-out recorded velocities: RMSE against the representative and every drop,
    log-spectral distance and peak error, paired ratios to linear with bootstrap CIs, the floors the
    recorded drops set, and run time. Works on datasets whose objects have different velocities."""
    from ..data.dataset import open_dataset
    from ..evaluation.report import figures, markdown, summarise
    from ..evaluation.runner import Method, methods_from, run_evaluation

    names = [m.strip() for m in methods.split(",") if m.strip()]
    rows = methods_from(names, config)
    training = {k: v for k, v in (("epochs", epochs), ("seed", seed)) if v is not None}
    rows = [Method(r.row, r.interpolator, r.options,
                   {**r.fit, "training": {**training, **r.fit.get("training", {})}} if training else r.fit)
            for r in rows]
    from ..evaluation.heldout import resolve

    ds = open_dataset(resolve(dataset, progress=say))
    if reducer not in ds.reducers():
        raise EffectError(f"dataset {ds.name!r} has no {reducer!r} bank; it has: {', '.join(ds.reducers())}")
    echo = say  # progress on stderr, tables on stdout
    echo(f"dataset {ds.name} ({reducer}), protocol {protocol}, methods {', '.join(r.row for r in rows)}")
    results = run_evaluation(ds, reducer, rows, protocol=protocol, repeats=repeats, echo=echo)
    summary = summarise(results, seed=seed)
    out.mkdir(parents=True, exist_ok=True)
    md = markdown(results, summary)
    (out / "tables.md").write_text(md)
    (out / "results.json").write_text(json.dumps({"results": results, "summary": summary}, indent=1) + "\n")
    pngs = figures(results, summary, {o: ds.bank(o, reducer) for o in ds.objects}, out)
    typer.echo(md)
    echo(f"wrote {out / 'tables.md'}, {out / 'results.json'}, " + ", ".join(map(str, pngs)))


def register(bench: typer.Typer) -> None:
    bench.command("interpolators")(interpolators)
