"""Learning curves: training and validation RMSE per epoch of one or more checkpoints, as a PNG."""

from __future__ import annotations

from pathlib import Path

from hapticfx.atomic import atomic_path


def curves_png(path: Path, runs: list[tuple[str, dict]], *, title: str) -> Path:
    """One panel per run (label, checkpoint metadata): train and validation RMSE per epoch, the starting
    validation RMSE (epoch 0: the weights training starts from, the untrained network's blend of the neighbours'
    centres or, when fine-tuning, the ``init`` checkpoint's) and the best epoch."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs), figsize=(5.2 * len(runs), 3.6), constrained_layout=True, squeeze=False)
    for ax, (label, meta) in zip(axes[0], runs):
        t = meta["training"]
        epochs = range(1, len(t["history"]) + 1)
        ax.plot(epochs, [h[0] for h in t["history"]], lw=1.0, color="#b5532a", label="train (inputs drawn from drop subsets)")
        ax.plot(epochs, [h[1] for h in t["history"]], lw=1.2, color="#1f5f99", label="validation (held-out targets)")
        start = t.get("start_val_rmse_normalised")
        if start is not None:
            start_from = "the pre-trained weights" if meta.get("init") else "the blend, untrained"
            ax.plot([0], [start], "o", color="#1f5f99", label=f"validation at epoch 0 ({start_from})")
        ax.axvline(t["best_epoch"], color="k", lw=0.7, ls=":", label=f"best epoch {t['best_epoch']}")
        ax.set_xlabel("epoch")
        ax.set_ylabel("RMSE (normalised by the neighbours' peak)")
        ax.set_title(f"{label}: {meta['parameters']:,} parameters, {t['train_time_s']:.0f} s", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    with atomic_path(Path(path), make_parents=True) as tmp:
        fig.savefig(tmp, dpi=100, format="png", metadata={"Software": "hapticfx", "Title": title})
    plt.close(fig)
    return Path(path)
