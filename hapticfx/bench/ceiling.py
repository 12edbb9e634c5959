"""``hapticfx bench ceiling``: how near the drop mean's floor a blend of two recorded neighbours could come."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from ..errors import DatasetError
from ..progress import say


def ceiling(
    dataset: str = typer.Argument(..., metavar="DATASET",
                                  help="A dense dataset: at least RECORDED + 10 drops per velocity (e.g. "
                                       "`hapticfx data synth OUT --spec SPEC --drops 60`)."),
    recorded: int = typer.Option(10, "--recorded", metavar="COUNT", min=2,
                                 help="Drops per velocity that play the recorded ones; the rest stand for the "
                                      "population."),
    method: str = typer.Option("ensemble-warp", "--method", metavar="NAME",
                               help="Interpolator fitted to the recorded drops alone and scored the same way "
                                    "(leave one velocity out), or a row named in --config; none: leave it out."),
    config: Optional[Path] = typer.Option(None, "--config", metavar="YAML",
                                          help="Rows as `bench interpolators --config` reads them: row -> "
                                          "{interpolator, options, model, training} (e.g. a network and how it "
                                          "trains; docs/neural.md)."),
    reducer: str = typer.Option("max-min", "--reducer", metavar="NAME", help="Which bank of the dataset."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="FILE", help="Also write the table and every "
                                       "fold as JSON."),
):
    """What the drop-mean measure of `bench interpolators` leaves to win: for every interior velocity of a dense
    set, linear, the morph of the neighbours' population means (the change between velocities a blend does not
    follow), of their recorded means (that and their noise) and of a method fitted to the recorded drops alone, in
    floors squared, and the gap shares they imply. See docs/interpolation.md."""
    import numpy as np

    from ..data.training import recorded_drops
    from ..evaluation.ceiling import method_values, object_folds, split, summarise
    from ..evaluation.heldout import open_with_bank
    from ..evaluation.runner import methods_from
    from ..timing import table

    row = None if method == "none" else methods_from([method], config)[-1]
    ds = open_with_bank(dataset, reducer, progress=say)
    splits = {}
    for obj in ds.objects:
        found = recorded_drops(ds, obj, reducer)
        if found is None:
            raise DatasetError(f"dataset {ds.name!r} keeps no drops of {obj!r} (no raw/ recordings)")
        say(f"{obj}: {found[1].shape[0]} velocities x {found[1].shape[1]} drops")
        splits[obj] = split(obj, *found, recorded)
    folds = [f for o in splits.values() for f in object_folds(o)]
    if not folds:
        raise DatasetError(f"dataset {ds.name!r}: no object has a velocity with recorded neighbours on both sides")
    scores = None if row is None else method_values(splits, row, reducer=reducer, rate_hz=ds.rate_hz,
                                                     dataset=ds.name, progress=say)
    rows = summarise(folds, scores)
    pen = lambda p: "-" if p is None else ("none" if not np.isfinite(p) else f"{p:g}")  # noqa: E731
    typer.echo(f"{ds.name} ({reducer}): {recorded} drops per velocity recorded; mean squares against the population "
               "mean, in floors squared (the sampling variance of a mean of that many drops)")
    extra = [] if scores is None else [method, f"gap share {method}"]
    typer.echo(table(["object", "folds", "warp penalty", "linear", "bias: morph of population means",
                      "morph of recorded means", *extra, "gap share ceiling", "gap share with recorded means"],
                     [[name, r["folds"], pen(r["penalty"]), f"{r['linear']:.2f}", f"{r['bias']:.2f}",
                       f"{r['recorded']:.2f}",
                       *([] if scores is None else [f"{r['method']:.2f}", f"{r['method_share']:.0%}"]),
                       f"{r['ceiling']:.0%}", f"{r['with_recorded']:.0%}"] for name, r in rows.items()]))
    if out is not None:
        from ..atomic import atomic_path

        with atomic_path(out) as tmp:
            Path(tmp).write_text(json.dumps({
                "dataset": ds.name, "reducer": reducer, "recorded": recorded,
                "method": None if scores is None else method,
                "summary": {k: {**r, "penalty": pen(r["penalty"])} for k, r in rows.items()},
                "folds": [{"object": f.object, "velocity": f.velocity, "w": f.w, "floor": f.floor,
                           "linear": f.linear, "bias": {pen(p): x for p, x in f.bias.items()},
                           "recorded": {pen(p): x for p, x in f.recorded.items()},
                           "method": None if scores is None else scores[(f.object, f.velocity)]}
                          for f in folds]}, indent=1) + "\n")
        say(f"wrote {out}")


def register(bench: typer.Typer) -> None:
    bench.command("ceiling")(ceiling)
