"""The `hapticfx train`, `hapticfx table` and `hapticfx bench threads` commands (torch is imported when they run)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from hapticfx.errors import EffectError


def train(
    config: Path = typer.Argument(..., help="Training configuration YAML (see docs/neural.md)."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", help="Checkpoint directory (overrides `out:` in the YAML)."),
    resume: bool = typer.Option(False, "--resume", help="Continue the run saved in the checkpoint directory."),
    epochs: Optional[int] = typer.Option(None, "--epochs", min=1, help="Override training.epochs."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    release: bool = typer.Option(False, "--release", help="At the end, delete the resume state (Adam moments, RNG) "
                                 "and keep only model.safetensors + model.json, e.g. for shipping weights."),
):
    """Train a neural interpolator on a dataset; writes model.safetensors, model.json and its velocity table."""
    from . import checkpoint
    from .config import load_config
    from .interpolator import require_torch
    from .run import train_from_config

    require_torch("`hapticfx train`")
    cfg = load_config(config)
    if out is not None:
        cfg.out = str(out)
    if epochs is not None:
        cfg.training["epochs"] = epochs
    meta, path = train_from_config(cfg, resume=resume, progress=not quiet)
    if release:
        for name in ("resume.safetensors", "resume.json"):
            (path.parent / name).unlink(missing_ok=True)
    t = meta["training"]
    typer.echo(f"{cfg.interpolator}: {t['epochs_run']} epochs in {t['train_time_s']:.1f} s, best epoch {t['best_epoch']} "
               f"(validation RMSE {t['best_val_rmse_normalised']:.4f} normalised), {meta['parameters']:,} parameters")
    typer.echo(f"wrote {path} and its velocity table {checkpoint.table_path(path).name}")


def table(
    weights: Path = typer.Argument(..., help="Checkpoint directory or .safetensors file."),
    dataset: Optional[str] = typer.Option(None, "--dataset", "-d", help="Dataset path or builtin:NAME (default: "
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


def register(app: typer.Typer, bench: typer.Typer) -> None:
    from .bench.table import bench_table
    from .bench.threads import threads

    app.command("train")(train)
    app.command("table")(table)
    bench.command("threads")(threads)
    bench.command("table")(bench_table)
