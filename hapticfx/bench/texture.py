"""``hapticfx bench texture``: what the spectral criteria leave to a method whose centre is right."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer

from ..cli.options import finite
from ..progress import say


def texture(
    datasets: List[str] = typer.Argument(..., metavar="DATASET...",
                                         help="Datasets with their drops (e.g. builtin:helmet-drops, "
                                              "heldout:heldout-even-height); each gets its own table."),
    reducer: str = typer.Option("max-min", "--reducer", metavar="NAME", help="Which bank of each dataset."),
    fills: List[float] = typer.Option([], "--fill", metavar="G", min=0.0, max=1.0, callback=finite,
                                      help="Also score each share with a spectral fill on top, as ensemble-warp "
                                           "fills: every bin above 100 Hz raised to G times linear's magnitude "
                                           "where lower, in phase, moved to where linear's fine detail is (repeat "
                                           "for several; docs/interpolation.md)."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="FILE", help="Also write the tables and every "
                                       "fold as JSON."),
):
    """The ceiling of the texture trade: for every interior velocity, the mean of its other drops (a right centre)
    with each texture share a method may keep, scored against the drop left out as `bench interpolators` scores
    (gap shares to the drop mean's and the representative's floors; LSD, ST-SIM, SPQI against every drop, as
    ratios to linear) and the criteria it meets. Where no share meets all four, no method of the residual form
    does by a better centre alone. The last row is a recorded drop of the velocity, each scored against the
    others on the spectral measures: where it is worse than linear, so are the recordings. See docs/interpolation.md."""
    from ..evaluation.heldout import open_with_bank
    from ..evaluation.texture_ceiling import dataset_folds, recorded, summarise
    from ..timing import table

    report = {}
    for name in datasets:
        ds = open_with_bank(name, reducer, progress=say)
        folds = dataset_folds(ds, reducer, fills=fills, progress=say)
        rows, real = summarise(folds, fills=fills), recorded(folds)
        report[name] = {"dataset": ds.name, "rows": rows, "recorded": real, "folds": [
            {"object": f.object, "velocity": f.velocity, "linear": f.linear, "floors": f.floors,
             "textured": {str(b): x for b, x in f.textured.items()},
             "filled": {f"{b} fill {g}": x for (b, g), x in f.filled.items()}, "recorded": f.recorded} for f in folds]}
        typer.echo(f"\n{name} ({reducer}, {len(folds)} folds): a right centre with each texture share, against linear")
        typer.echo(table(["texture", "gap share (drop mean)", "gap share (rep)", "LSD / linear", "ST-SIM / linear",
                          "SPQI / linear", "criteria"],
                         [[f"{r['texture']:.1f}" + (f" + fill {r['fill']:g}" if r["fill"] else ""),
                           f"{r['share_mean']:.0%}", f"{r['share_rep']:.0%}",
                           f"{r['lsd']:.3f}x", f"{r['stsim']:.3f}x", f"{r['spqi']:.3f}x", f"{r['criteria']}/4"]
                          for r in rows]
                         + [["a recorded drop", "-", "-", f"{real['lsd']:.3f}x", f"{real['stsim']:.3f}x",
                             f"{real['spqi']:.3f}x", f"{int(real['lsd_met']) + int(real['perceptual_met'])}/2 spectral"]]))
    if out is not None:
        from ..atomic import atomic_path

        with atomic_path(out) as tmp:
            Path(tmp).write_text(json.dumps({"reducer": reducer, "datasets": report}, indent=1) + "\n")
        say(f"wrote {out}")


def register(bench: typer.Typer) -> None:
    bench.command("texture")(texture)
