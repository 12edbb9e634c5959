"""Summaries, Markdown tables and figures of an evaluation run (``hapticfx bench interpolators``).

Every ratio is paired: a method and linear are scored on the same folds, and the
95 % confidence interval of ``sum(method) / sum(linear)`` comes from resampling the
folds with replacement (percentile bootstrap, seeded).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

MEASURES = (  # key in a fold entry, label, transform, the floor its gap share is measured to, higher is better
    ("rmse", "RMSE vs representative (g)", None, "mean_of_others_rmse", False),
    ("rmse_mean", "RMSE vs the mean of the held-out drops (g)", None, "mean_sampling_rmse", False),
    ("rmse_drops", "RMSE vs every drop (g)", None, None, False),
    ("lsd_db", "log-spectral distance 20-500 Hz vs representative (dB)", None, None, False),
    ("lsd_drops_db", "log-spectral distance 20-500 Hz vs every drop (dB)", None, "drop_pairs_lsd_db", False),
    ("peak_db", "|peak error| (dB)", np.abs, None, False),
    ("stsim", "ST-SIM vs every drop (1 = identical; higher is better)", None, "drop_to_drop_stsim", True),
    ("spqi", "SPQI vs every drop (1 = identical; higher is better)", None, "drop_to_drop_spqi", True),
)
FLOOR_ROWS = {  # measure -> floors shown under its table
    "rmse": ["drop_to_drop_rmse", "mean_of_others_rmse"], "rmse_mean": ["mean_sampling_rmse"],
    "lsd_db": ["drop_to_drop_lsd_db"], "lsd_drops_db": ["drop_pairs_lsd_db", "mean_of_others_lsd_db"],
    "peak_db": ["drop_to_drop_peak_db"], "stsim": ["drop_to_drop_stsim", "mean_of_others_stsim"],
    "spqi": ["drop_to_drop_spqi", "mean_of_others_spqi"],
}
IDEAL_LABEL = "reference: the mean of the other drops against each (the RMSE floors' ideal)"
FLOOR_LABELS = {
    "drop_to_drop_rmse": "floor: another drop at the same velocity",
    "mean_of_others_rmse": "floor: mean of the other drops (partly circular: the representative is their medoid)",
    "mean_sampling_rmse": "floor: sampling error of the drops' mean",
    "drop_to_drop_lsd_db": "floor: another drop at the same velocity",
    "drop_pairs_lsd_db": "floor: a recorded drop against the others",
    "drop_to_drop_peak_db": "floor: another drop at the same velocity",
    "drop_to_drop_stsim": "ceiling: a recorded drop against the others",
    "drop_to_drop_spqi": "ceiling: a recorded drop against the others",
    "mean_of_others_lsd_db": IDEAL_LABEL,
    "mean_of_others_stsim": IDEAL_LABEL,
    "mean_of_others_spqi": IDEAL_LABEL,
}


def _paired(values: np.ndarray, base: np.ndarray, rng: np.random.Generator, boot: int) -> tuple[float, float, float]:
    idx = rng.integers(0, len(values), size=(boot, len(values)))
    with np.errstate(divide="ignore", invalid="ignore"):  # a measure linear scores 0 on (a saturated SPQI)
        ratio = float(values.sum() / base.sum())
        samples = values[idx].sum(axis=1) / base[idx].sum(axis=1)
    lo, hi = np.nanpercentile(samples, [2.5, 97.5]) if np.isfinite(samples).any() else (np.nan, np.nan)
    return ratio, float(lo), float(hi)


def gap_share(values: np.ndarray, base: np.ndarray, floor: np.ndarray, rng: np.random.Generator, boot: int, *,
              higher: bool = False) -> tuple[float, float, float]:
    """``(linear - method) / (linear - floor)`` over the folds' sums, with a 95 % bootstrap CI over folds.

    0: no better than linear; 1: at the floor (for a higher-is-better measure the same formula
    with the ceiling). NaN when the floor is not better than linear on the whole set: there is
    no gap to share. A resample with no gap counts as -inf (conservative: it can only lower the
    interval's lower bound).
    """
    def share(v, b, f):
        gap = (f - b) if higher else (b - f)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(gap > 1e-12 * np.maximum(np.abs(b), 1e-300), (b - v) / (b - f), -np.inf)

    point = float(share(values.sum(), base.sum(), floor.sum()))
    if not np.isfinite(point):
        return float("nan"), float("nan"), float("nan")
    idx = rng.integers(0, len(values), size=(boot, len(values)))
    samples = share(values[idx].sum(axis=1), base[idx].sum(axis=1), floor[idx].sum(axis=1))
    lo, hi = np.percentile(samples, [2.5, 97.5], method="nearest")  # no interpolation across -inf
    return point, float(lo), float(hi)


def summarise(results: dict, *, boot: int = 2000, seed: int = 0) -> dict:
    """Per method: means, paired ratios to linear with bootstrap CIs, wins, timings; the floors."""
    rng = np.random.default_rng(seed)
    rows = results["methods"]
    lin = {(e["object"], e["velocity"]): e for e in rows["linear"]["folds"]}
    out = {"floors": {}, "methods": {}, "objects": {}}
    folds = results["folds"]
    floor_of = {(f["object"], f["velocity"]): f for f in folds}
    for key in FLOOR_LABELS:
        vals = [f[key] for f in folds if key in f]
        if vals:
            out["floors"][key] = float(np.mean(vals))
    for name, row in rows.items():
        if row["error"] or not row["folds"]:
            out["methods"][name] = {"error": row["error"] or "no folds"}
            continue
        entries = row["folds"]
        s = {"n": len(entries), "fit_s": float(np.mean([f["fit_s"] for f in row["fits"]]))}
        for key, _, fn, floor_key, higher in MEASURES:
            if not all(key in e for e in entries):
                continue
            v = np.array([e[key] for e in entries])
            b = np.array([lin[(e["object"], e["velocity"])][key] for e in entries])
            if fn is not None:
                v, b = fn(v), fn(b)
            s[key] = float(v.mean())
            s[f"{key}_ratio"] = _paired(v, b, rng, boot)
            s[f"{key}_wins"] = int(np.sum(v > b) if higher else np.sum(v < b))
            floors = [floor_of[(e["object"], e["velocity"])].get(floor_key) for e in entries] if floor_key else [None]
            if None not in floors and np.all(np.isfinite(floors)):
                s[f"{key}_share"] = gap_share(v, b, np.array(floors, dtype=float), rng, boot, higher=higher)
        for k in ("latency_ms", "table_latency_ms"):
            if k in row:
                s[k] = row[k]
        diffs = [e["table_vs_direct"] for e in entries if "table_vs_direct" in e]
        if diffs:
            s["table_vs_direct_max"] = float(max(diffs))
        s["extra"] = {k: v for k, v in row["fits"][0].items() if k != "fit_s"} if row["fits"] else {}
        if any("best_epoch" in f for f in row["fits"]):  # a learned row: the epoch each round kept
            s["best_epochs"] = [f.get("best_epoch") for f in row["fits"]]
        if any("texture" in f for f in row["fits"]):  # the share of fine detail each round's fit chose or was given
            s["textures"] = [f.get("texture") for f in row["fits"]]
        if any(f.get("fill") for f in row["fits"]):  # and the spectral fill on top of it (ensemble-warp's fill)
            s["fills"] = [f.get("fill") or 0.0 for f in row["fits"]]
        out["methods"][name] = s
    for obj in dict.fromkeys(f["object"] for f in folds):
        per = {}
        base = np.array([e["rmse"] for e in rows["linear"]["folds"] if e["object"] == obj])
        for name, row in rows.items():
            if row["error"]:
                continue
            v = np.array([e["rmse"] for e in row["folds"] if e["object"] == obj])
            per[name] = float(v.sum() / base.sum()) if len(v) == len(base) and base.sum() > 0 else float("nan")
        floor = [f["mean_of_others_rmse"] for f in folds if f["object"] == obj and "mean_of_others_rmse" in f]
        if floor:
            per["floor: mean of other drops"] = float(np.sum(floor) / base.sum())
        out["objects"][obj] = per
    return out


def _ci(t) -> str:
    return f"{t[0]:.3f} [{t[1]:.3f}, {t[2]:.3f}]"


def markdown(results: dict, summary: dict) -> str:
    """The tables of one run, in Markdown."""
    n = len(results["folds"])
    lines = [f"Dataset `{results['dataset']}` (reducer `{results['reducer']}`), protocol `{results['protocol']}`: "
             f"{results['rounds']} rounds, {n} folds. Ratios are paired against linear on the same folds; "
             "share of the gap = (linear - method) / (linear - floor); 95 % bootstrap CIs over folds in brackets. "
             "Lower is better except for ST-SIM and SPQI.", ""]
    names = [m for m, s in summary["methods"].items() if "error" not in s]
    for key, label, _, floor_key, _ in MEASURES:
        if not all(key in summary["methods"][m] for m in names):
            continue
        lines += [f"### {label}", "", "| method | mean | / linear [95 % CI] | share of the gap [95 % CI] "
                  "| folds better than linear |", "|---|---|---|---|---|"]
        for m in names:
            s = summary["methods"][m]
            share = "-" if f"{key}_share" not in s else (
                _ci(s[f"{key}_share"]) if np.isfinite(s[f"{key}_share"][0]) else "no gap: floor not better than linear")
            lines.append(f"| {m} | {s[key]:.4f} | {_ci(s[f'{key}_ratio'])} | {share} | {s[f'{key}_wins']}/{s['n']} |")
        fl = summary["floors"]
        base = summary["methods"]["linear"][key]
        for fk in FLOOR_ROWS.get(key, []):
            if fk in fl:
                lines.append(f"| *{FLOOR_LABELS[fk]}* | {fl[fk]:.4f} | {fl[fk] / base:.3f} | "
                             f"{'1' if fk == floor_key else ''} | |")
        lines.append("")
    lines += ["### Run time", ""]
    if results.get("processes", 1) > 1:
        lines += [f"Rounds ran in {results['processes']} processes side by side: these times were taken beside "
                  "each other.", ""]
    lines += ["| method | fit per round (s) | best epoch per round | texture per round | "
              "direct median / p99 (ms) | served from a table median / p99 (ms) | table vs direct (max relative) |",
              "|---|---|---|---|---|---|---|"]
    for m in names:
        s = summary["methods"][m]
        lat = s.get("latency_ms")
        tab = s.get("table_latency_ms")
        epochs = ", ".join(str(e) for e in s.get("best_epochs", [])) or "-"
        fills = s.get("fills", [0.0] * len(s.get("textures", [])))
        textures = ", ".join(f"{t:g}" + (f" fill {g:g}" if g else "")
                             for t, g in zip(s.get("textures", []), fills)) or "-"
        lines.append(f"| {m} | {s['fit_s']:.2f} | {epochs} | {textures} | "
                     + (f"{lat['median']:.4f} / {lat['p99']:.4f}" if lat else "-") + " | "
                     + (f"{tab['median']:.4f} / {tab['p99']:.4f}" if tab else "-") + " | "
                     + (f"{s['table_vs_direct_max']:.1e}" if "table_vs_direct_max" in s else "-") + " |")
    lines += ["", "### RMSE / linear per object", "", "| object | " + " | ".join(summary["objects"][next(iter(
        summary["objects"]))]) + " |", "|---|" + "---|" * len(summary["objects"][next(iter(summary["objects"]))])]
    for obj, per in summary["objects"].items():
        lines.append(f"| {obj} | " + " | ".join(f"{v:.3f}" for v in per.values()) + " |")
    failed = {m: s["error"] for m, s in summary["methods"].items() if "error" in s}
    if failed:
        lines += ["", "Not evaluated: " + "; ".join(f"{m}: {e}" for m, e in failed.items())]
    return "\n".join(lines) + "\n"


def figures(results: dict, summary: dict, banks: dict, out: Path) -> list[Path]:
    """``error_vs_runtime.png`` (RMSE and log-spectral distance against run time, floors drawn in)
    and ``examples.png`` (the middle round's predictions beside the held-out drops)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [m for m, s in summary["methods"].items() if "error" not in s]
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    markers = "osD^vP*Xh<>"
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4))
    for ax, key, floor_keys, label in ((axes[0], "rmse", ("drop_to_drop_rmse", "mean_of_others_rmse"), "RMSE (g)"),
                                       (axes[1], "lsd_db", ("drop_to_drop_lsd_db",), "log-spectral distance (dB)")):
        for i, m in enumerate(names):
            s = summary["methods"][m]
            style = dict(color=colours[i % len(colours)], marker=markers[i % len(markers)], s=40, zorder=3)
            if "latency_ms" in s:  # filled: as served (a table where there is one); hollow: direct inference
                served = (s.get("table_latency_ms") or s["latency_ms"])["median"]
                ax.scatter(served, s[key], label=m, **style)
                if "table_latency_ms" in s:
                    ax.scatter(s["latency_ms"]["median"], s[key], facecolors="none", edgecolors=style["color"],
                               marker=style["marker"], s=40, zorder=3)
                    ax.plot([served, s["latency_ms"]["median"]], [s[key]] * 2, color=style["color"], lw=0.6, alpha=0.5)
        styles = iter(("--", ":"))
        for fk in floor_keys:
            if fk in summary["floors"]:
                what = "another drop" if fk.startswith("drop_to_drop") else "mean of the other drops"
                ax.axhline(summary["floors"][fk], color="grey", ls=next(styles), lw=1, label=f"floor: {what}")
        ax.set_xscale("log")
        ax.set_xlabel("run time per profile, median (ms)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="center right", fontsize=8, frameon=False)
    fig.suptitle(f"{results['dataset']} ({results['reducer']}), {results['protocol']}: error against run time "
                 "(filled: as served, from a velocity table where there is one; hollow: direct inference)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 0.83, 1))
    paths = [out / "error_vs_runtime.png"]
    fig.savefig(paths[0], dpi=110)
    plt.close(fig)

    kept = {m: results["methods"][m].get("predictions", {}) for m in names}
    keys = list(next((k for k in kept.values() if k), {}))
    if not keys:
        return paths
    fig, axes = plt.subplots(len(keys), 1, figsize=(9, 2.1 * len(keys)), squeeze=False)
    for ax, key in zip(axes[:, 0], keys):
        obj, v = key.rsplit("@", 1)
        bank = banks[obj]
        t = np.arange(bank.n_samples) / bank.rate_hz * 1e3
        ax.plot(t, bank.profiles[bank.index_of(float(v))], color="k", lw=1.3, label="held-out representative")
        for m in names:
            if key in kept[m]:
                ax.plot(t, kept[m][key], lw=0.9, ls=":" if m == "linear" else "-", label=m)
        ax.set_xlim(0, t[-1] * 0.6)
        ax.set_ylabel(f"{obj}\n{float(v):.2f} m/s (g)", fontsize=8)
        ax.grid(alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    ncol = min(5, len(labels))
    rows = -(-len(labels) // ncol)
    top = 1 - (0.12 + 0.1 * rows) / (2.1 * len(keys))  # the legend's height above the panels, not over the data
    fig.legend(handles, labels, loc="upper center", ncol=ncol, fontsize=7, frameon=False)
    axes[-1, 0].set_xlabel("time (ms)")
    fig.tight_layout(rect=(0, 0, 1, top))
    paths.append(out / "examples.png")
    fig.savefig(paths[1], dpi=110)
    plt.close(fig)
    return paths
