"""The `hapticfx train` and `hapticfx bench interpolators` commands (torch is imported when they run)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from hapticfx.errors import EffectError

from . import checkpoint


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


def _floats(text: Optional[str], name: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise EffectError(f"--{name} must be comma-separated velocities in m/s, got {text!r}") from None


def interpolators(
    dataset: str = typer.Option("builtin:helmet-drops", "--dataset", "-d", help="Dataset path or builtin:NAME."),
    reducer: str = typer.Option("max-min", "--reducer", help="Which bank of the dataset."),
    methods: str = typer.Option("linear,lstm,bilstm,lstm-sae,bilstm-ed,convlstm-ed,convbilstm", "--methods",
                                help="Comma-separated interpolators (linear is always included as the baseline)."),
    train_v: Optional[str] = typer.Option(None, "--train", help="Training target velocities (default: the paper's "
                                          "2.80,3.13,3.43,4.85,5.05 when recorded, else all interior ones not tested)."),
    test_v: Optional[str] = typer.Option(None, "--test", help="Test velocities (default: the paper's 3.96,4.43 when "
                                         "recorded, else two interior velocities near 1/3 and 2/3 of the range)."),
    epochs: int = typer.Option(100, "--epochs", min=1, help="Maximum epochs per network (early stopping may end sooner)."),
    cv: bool = typer.Option(True, "--cv/--no-cv", help="Leave-one-velocity-out cross-validation."),
    cv_methods: Optional[str] = typer.Option(None, "--cv-methods", help="Methods in the cross-validation (default: all)."),
    cv_epochs: int = typer.Option(30, "--cv-epochs", min=1, help="Maximum epochs per network per fold."),
    cached: str = typer.Option("convbilstm", "--cached", help="Methods also measured in cached mode (comma-separated)."),
    grid_step: float = typer.Option(0.01, "--grid-step", min=1e-4, help="Cache grid spacing in m/s."),
    repeats: int = typer.Option(50, "--repeats", min=5, help="Latency measurements per method."),
    seed: int = typer.Option(0, "--seed", help="Training seed."),
    config: Optional[Path] = typer.Option(None, "--config", help="YAML mapping method -> {model: ..., training: ...} overrides."),
    out: Path = typer.Option(Path("bench-interpolators"), "--out", "-o", help="Directory for the tables (markdown, JSON) and PNGs."),
):
    """Paper protocol (Tables 2, 3): train per method, test at held-out velocities; error against run time."""
    from .bench import BenchOptions, run_bench

    opts = BenchOptions(
        dataset=dataset, reducer=reducer, methods=[m.strip() for m in methods.split(",") if m.strip()],
        train=_floats(train_v, "train"), test=_floats(test_v, "test"), epochs=epochs, cv=cv,
        cv_methods=None if cv_methods is None else [m.strip() for m in cv_methods.split(",") if m.strip()],
        cv_epochs=cv_epochs, cached=[m.strip() for m in cached.split(",") if m.strip()], grid_step=grid_step,
        repeats=repeats, seed=seed, config=config, out=out,
    )
    run_bench(opts, echo=typer.echo)


def register(app: typer.Typer, bench: typer.Typer) -> None:
    from .bench_threads import threads

    app.command("train")(train)
    app.command("table")(table)
    bench.command("interpolators")(interpolators)
    bench.command("threads")(threads)
