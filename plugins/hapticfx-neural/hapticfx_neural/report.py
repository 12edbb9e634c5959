"""Markdown tables and PNG figures of `hapticfx bench interpolators`."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _fmt(x: float, nd: int = 4) -> str:
    return f"{x:.{nd}f}"


def _pair(d: dict | None) -> str:
    return "-" if d is None else f"{d['mean']:.2e} / {d['max']:.2e}"


def tables(r: dict) -> str:
    """Table 2 (RMSE per object and test velocity), Table 3 (averages, run time), cache, continuity, CV."""
    methods = list(r["methods"])
    lin = r["methods"]["linear"]
    objects = sorted({o for (o, _) in lin["rmse"]}, key=lambda o: list(k[0] for k in lin["rmse"]).index(o))
    lines = [f"Dataset `{r['dataset']}` (reducer `{r['reducer']}`); train targets {r['train']} m/s, "
             f"test {r['test']} m/s; at most {r['epochs']} epochs (early stopping on a validation split), "
             f"seed {r['seed']}, torch threads {r['torch_threads']}. RMSE in g.", "",
             "### Table 2: RMSE per object and test velocity", "",
             "| object | velocity (m/s) | " + " | ".join(methods) + " |",
             "|---|---|" + "---|" * len(methods)]
    for obj in objects:
        for v in r["test"]:
            lines.append(f"| {obj} | {v:.2f} | " + " | ".join(_fmt(r["methods"][m]["rmse"][(obj, v)]) for m in methods) + " |")
    lines += ["", "### Table 3: averaged RMSE and run time", "",
              "| method | avg RMSE | RMSE / linear | training (s) | epochs (best) | latency median (ms) | "
              "latency p99 (ms) | latency / linear | parameters |",
              "|---|---|---|---|---|---|---|---|---|"]
    for m in methods:
        x = r["methods"][m]
        ep = f"{x['epochs_run']} ({x['best_epoch']})" if "epochs_run" in x else "-"
        lines.append(f"| {m} | {_fmt(x['avg_rmse'])} | {x['avg_rmse'] / lin['avg_rmse']:.2f} | {x['train_s']:.1f} | {ep} | "
                     f"{x['latency']['median_ms']:.3f} | {x['latency']['p99_ms']:.3f} | "
                     f"{x['latency']['median_ms'] / lin['latency']['median_ms']:.0f} | {x['parameters']:,} |")
    cached = [m for m in methods if "cache" in r["methods"][m]]
    if cached:
        lines += ["", "### Cached mode (profiles precomputed on a velocity grid at effect load, blended linearly)", "",
                  "Added error: RMS difference from direct inference at the midpoints between grid nodes, "
                  "relative to the RMS of the object's recorded profiles.", "",
                  "| method | grid (m/s) | profiles per object | build per object (s) | cached latency median / p99 (ms) | "
                  "direct latency median / p99 (ms) | avg test RMSE cached | avg test RMSE direct | "
                  "added error vs direct, between network nodes (mean / max) | "
                  "added error vs direct, half-steps next to recorded velocities (mean / max) |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for m in cached:
            x, c = r["methods"][m], r["methods"][m]["cache"]
            lines.append(f"| {m} | {c['grid_step_mps']} | {c['profiles_per_object']} | {c['build_s_per_object']:.2f} | "
                         f"{c['latency']['median_ms']:.4f} / {c['latency']['p99_ms']:.4f} | "
                         f"{x['latency']['median_ms']:.3f} / {x['latency']['p99_ms']:.3f} | "
                         f"{_fmt(float(np.mean(list(c['rmse'].values()))))} | {_fmt(x['avg_rmse'])} | "
                         f"{_pair(c['added_rel'].get('inner'))} | {_pair(c['added_rel'].get('ends'))} |")
    lines += ["", "### Continuity at recorded velocities (+-1e-6 m/s) and range 0-20 m/s (through the data-driven model)", "",
              "| method | mode | largest jump RMS (g) | relative to recorded RMS | where | finite 0-20 m/s | outside policy |",
              "|---|---|---|---|---|---|---|"]
    for m in methods:
        for mode, c in r["methods"][m]["continuity"].items():
            where = f"{c['object']} @ {c['velocity']:.2f}" if c["object"] else "-"
            lines.append(f"| {m} | {mode} | {c['jump_g']:.3g} | {c['relative']:.3g} | {where} | {c['finite_0_20']} | "
                         f"{c['outside']} |")
    if "cv" in r:
        lines += ["", f"### Leave-one-velocity-out cross-validation (each interior velocity; at most {r['cv_epochs']} "
                  "epochs per fold)", "", "| method | mean RMSE | std over folds | mean / linear |", "|---|---|---|---|"]
        lin_cv = r["cv"]["linear"]["mean"]
        for m, c in r["cv"].items():
            lines.append(f"| {m} | {_fmt(c['mean'])} | {_fmt(c['std'])} | {c['mean'] / lin_cv:.2f} |")
    return "\n".join(lines) + "\n"


def figures(r: dict, preds: dict, banks: dict, out: Path) -> None:
    """``error_vs_latency.png`` (log axes, one point per method) and ``fig8.png`` (paper Fig. 8)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for m, x in r["methods"].items():
        ax.scatter(x["latency"]["median_ms"], x["avg_rmse"], s=40)
        ax.annotate(m, (x["latency"]["median_ms"], x["avg_rmse"]), textcoords="offset points", xytext=(5, 4), fontsize=8)
        if "cache" in x:
            c = x["cache"]
            lat, err = c["latency"]["median_ms"], float(np.mean(list(c["rmse"].values())))
            ax.scatter(lat, err, s=40, marker="s")
            ax.annotate(f"{m} (cached)", (lat, err), textcoords="offset points", xytext=(5, -10), fontsize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("inference latency per impact, median (ms, batch 1, %d threads)" % r["torch_threads"])
    ax.set_ylabel("average test RMSE (g)")
    ax.set_title(f"{r['dataset']}: error against latency")
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "error_vs_latency.png", dpi=120)
    plt.close(fig)

    v = r["test"][0]
    objs = list(banks)
    # linear, every ConvBiLSTM row, and the most accurate other network
    nets = sorted((x["avg_rmse"], m) for m, x in r["methods"].items() if m != "linear")
    shown = ["linear"] + [m for _, m in nets if m.startswith("convbilstm")]
    shown += [m for _, m in nets if m not in shown][:1]
    fig, axes = plt.subplots(len(objs), 1, figsize=(8, 2.2 * len(objs)), sharex=True, squeeze=False)
    for ax, obj in zip(axes[:, 0], objs):
        bank = banks[obj]
        t = np.arange(bank.n_samples) / bank.rate_hz * 1e3
        ax.plot(t, bank.profiles[bank.index_of(v)], color="k", lw=1.2, label="measured")
        for m in shown:
            if (m, obj, v) in preds:
                ax.plot(t, preds[(m, obj, v)], ls=":" if m == "linear" else "-", lw=1, label=f"estimated ({m})")
        ax.set_ylabel(f"{obj}\n(g)", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="upper right")
    axes[0, 0].set_title(f"Measured and estimated profiles at {v:.2f} m/s ({r['dataset']}, {r['reducer']})")
    axes[-1, 0].set_xlabel("time (ms)")
    fig.tight_layout()
    fig.savefig(out / "fig8.png", dpi=120)
    plt.close(fig)
