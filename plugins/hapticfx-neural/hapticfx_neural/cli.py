"""The `hapticfx train`, `hapticfx table` and `hapticfx bench threads` commands (torch is imported when they run)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from hapticfx.errors import EffectError


def train(
    config: Path = typer.Argument(..., help="Training configuration YAML (see docs/neural.md)."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="DIR",
                                       help="Checkpoint directory (overrides `out:` in the YAML; "
                                       "default: checkpoints/<interpolator>-<dataset>-<reducer> here)."),
    ship: bool = typer.Option(False, "--ship", help="Replace the plugin's shipped weights for the dataset and "
                              "reducer (what effects use without `weights:`) with this run's, once it has "
                              "finished: it trains in checkpoints/ship-<interpolator>-<dataset>-<reducer> here "
                              "(an interrupted run leaves the shipped weights as they were; --ship --resume "
                              "continues it); implies --release."),
    resume: bool = typer.Option(False, "--resume", help="Continue the run saved in the checkpoint directory."),
    epochs: Optional[int] = typer.Option(None, "--epochs", metavar="COUNT", min=1, help="Override training.epochs."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    curves: Optional[Path] = typer.Option(None, "--curves", metavar="PNG",
                                          help="Also write the learning curves (train and "
                                          "validation RMSE per epoch) to this PNG."),
    release: bool = typer.Option(False, "--release", help="At the end, delete the resume state (Adam moments, RNG) "
                                 "and keep only model.safetensors + model.json, e.g. for shipping weights."),
    force: bool = typer.Option(False, "--force", help="Replace a --curves file that hapticfx did not write (its own "
                               "PNG is replaced anyway)."),
):
    """Train a neural interpolator on every drop of a dataset (or several: pre-training); writes model.safetensors,
    model.json and its velocity table. The shipped weights change only with --ship."""
    from . import checkpoint
    from .config import load_config
    from .interpolator import require_torch
    from .run import train_from_config

    require_torch("`hapticfx train`")
    cfg = load_config(config)
    if curves is not None:
        _check_curves(curves, force=force)
    if ship and out is not None:
        raise EffectError("give --ship or --out, not both")
    if ship:
        if len(cfg.datasets) != 1:
            raise EffectError("only a network trained on one dataset can be shipped", source=str(config), key="dataset")
        from hapticfx.data.dataset import open_dataset

        name = open_dataset(cfg.dataset, relative_to=config.parent).name
        shipped = checkpoint.WEIGHTS_DIR / name / cfg.reducer / cfg.interpolator
        cfg.out = str(Path("checkpoints") / f"ship-{cfg.interpolator}-{name}-{cfg.reducer}")
        release = True
    elif out is not None:
        cfg.out = str(out)
    if epochs is not None:
        cfg.training["epochs"] = epochs
    meta, path = train_from_config(cfg, resume=resume, progress=not quiet)
    if release:
        for name in ("resume.safetensors", "resume.json"):
            (path.parent / name).unlink(missing_ok=True)
    if ship:
        path = _swap_in(path, shipped)
    t = meta["training"]
    typer.echo(f"{cfg.interpolator}: {t['epochs_run']} epochs in {t['train_time_s']:.1f} s, best epoch {t['best_epoch']} "
               f"(validation RMSE {t['best_val_rmse_normalised']:.4f} normalised), {meta['parameters']:,} parameters")
    if meta.get("texture"):
        kept = meta["texture"]
        typer.echo(f"texture: its profiles keep {kept['share']:g} of the neighbours' detail above 100 Hz "
                   f"({kept['chosen_on']})")
    typer.echo(f"wrote {path}" + (f" and its velocity table {checkpoint.table_path(path).name}"
                                  if checkpoint.table_path(path).is_file() else ""))
    if curves is not None:
        from .curves import curves_png

        title = f"{cfg.interpolator} on {meta['dataset']['name']}"
        if meta.get("init"):
            title += f", fine-tuned from weights pre-trained on {meta['init']['dataset']}"
        typer.echo(f"wrote {curves_png(curves, [(cfg.interpolator, meta)], title=title)}")


def _check_curves(path: Path, *, force: bool) -> None:
    """Refuse a --curves path the PNG could not be written to after training: another suffix, a directory, a
    file hapticfx did not write (unless ``force``), a folder above it that is a file."""
    from hapticfx.actuators.files import check_overwrite
    from hapticfx.atomic import existing_folder

    if path.suffix.lower() != ".png":
        raise EffectError(f"--curves {path}: expected a .png file name, got {path.suffix or 'none'!r}")
    check_overwrite(path, force=force)
    existing_folder(path.parent)


def _swap_in(weights: Path, shipped: Path) -> Path:
    """Move a finished run's folder (``weights``' parent) into place as ``shipped``, replacing the folder there
    by renames, so that no reader meets new weights beside an old velocity table; returns the weights' new path."""
    import shutil

    new, old = shipped.with_name(f".{shipped.name}.new"), shipped.with_name(f".{shipped.name}.old")
    for leftover in (new, old):
        shutil.rmtree(leftover, ignore_errors=True)
    shipped.parent.mkdir(parents=True, exist_ok=True)
    shutil.move(weights.parent, new)  # a rename, or a copy where checkpoints/ is on another file system
    if shipped.exists():
        shipped.rename(old)
    new.rename(shipped)
    shutil.rmtree(old, ignore_errors=True)
    return shipped / weights.name


def table(
    weights: Path = typer.Argument(..., help="Checkpoint directory or .safetensors file."),
    dataset: Optional[str] = typer.Option(None, "--dataset", "-d", metavar="DATASET",
                                          help="Dataset path or builtin:NAME (default: "
                                          "the one the checkpoint was trained on)."),
):
    """Write the velocity table of a trained interpolator: what effects play without torch.

    `hapticfx train` writes it already; run this after changing the dataset's banks, or for weights
    trained elsewhere. The table covers every object of the dataset.
    """
    from hapticfx.data.dataset import open_dataset

    from . import checkpoint
    from .interpolator import require_torch
    from .tables import write_table

    require_torch("`hapticfx table`")
    path = checkpoint.resolve(weights)
    meta = checkpoint.read_meta(path)
    ref = dataset or meta["dataset"].get("ref")
    if ref is None:
        raise EffectError(f"{path}: the checkpoint does not say where its dataset is; give --dataset")
    written = write_table(path, open_dataset(ref), progress=typer.echo)
    typer.echo(f"wrote {written}")


def simulate(
    out: Path = typer.Argument(..., help="Folder for the specs (specs/) and the simulated datasets."),
    rigs: int = typer.Option(8, "--rigs", metavar="COUNT", min=1, max=10_000,
                             help="How many random rigs (specs) to draw."),
    first: int = typer.Option(0, "--first", metavar="INDEX", min=0,
                              help="Index of the first draw (to add rigs to a folder)."),
    workers: int = typer.Option(2, "--workers", metavar="COUNT", min=1, max=64,
                                help="Processes simulating drops in parallel."),
):
    """Simulate drop sets for pre-training: random rigs and objects from written-down ranges, dense velocity grids.

    Rigs and objects come from the core's ranges (hapticfx.droprig.draws), every object on its own
    16-velocity grid every 0.05 m/s with 5 drops, seeds 7000000 + k (never a held-out set's; see
    hapticfx_neural/pretrain/draws.py and docs/neural.md). Each rig is written as a
    `hapticfx data synth --spec` file under OUT/specs and simulated into OUT/pretrain-<k>; train on
    them with `dataset: [OUT/pretrain-0, ...]` and fine-tune with `init:`.
    """
    import time

    from hapticfx.droprig.spec import load_spec
    from hapticfx.droprig.synth import synth_dataset
    from hapticfx.progress import say

    from .pretrain.draws import write_specs

    started = time.perf_counter()
    specs = write_specs(out / "specs", first + rigs)[first:]
    for spec in specs:
        s = load_spec(spec)
        path = synth_dataset(out / spec.stem, s.objects, s.velocities, drops=s.drops, seed=s.seed, name=s.name,
                             rig=s.rig, workers=workers, overwrite=True, progress=say,
                             command=f"hapticfx pretrain-data {out} (spec {spec.name})")
        typer.echo(f"wrote {path}")
    typer.echo(f"{len(specs)} rig(s) simulated in {time.perf_counter() - started:.0f} s")


def register(app: typer.Typer, bench: typer.Typer) -> None:
    from .bench.learnable import learnable
    from .bench.table import bench_table
    from .bench.threads import threads

    app.command("train")(train)
    app.command("table")(table)
    app.command("pretrain-data")(simulate)
    bench.command("threads")(threads)
    bench.command("table")(bench_table)
    bench.command("learnable")(learnable)
