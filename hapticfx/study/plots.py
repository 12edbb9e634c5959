"""PNG figures of a study's analysis, after the paper's Figs. 10-15 (matplotlib, imported when drawing)."""

from __future__ import annotations

from pathlib import Path

from ..atomic import atomic_path
from .analysis import Analysis, MatchingResult, RatingResult


def _figure(width: float, height: float, panels: int = 1):
    """pyplot, a figure and its ``panels`` axes side by side (one axes when ``panels`` is 1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, panels, figsize=(width, height), dpi=110, squeeze=False)
    return plt, fig, axes[0] if panels > 1 else axes[0][0]


def _save(plt, fig, path: Path) -> Path:
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return path


def _label(row, factors) -> str:
    return "\n".join(str(row[f]) for f in factors)


def rating_bars(r: RatingResult, path: Path) -> Path:
    """Mean rating per condition with 95% confidence intervals (Figs. 10, 15 and 16); reference lines for similarity."""
    means = r.means.sort_values(r.factors).reset_index(drop=True)
    plt, fig, ax = _figure(max(5.0, 0.55 * len(means) + 2), 4.2)
    err = [means["mean"] - means.ci_low, means.ci_high - means["mean"]]
    ax.bar(range(len(means)), means["mean"], yerr=err, capsize=3, color="#6a9fb5", edgecolor="#2f5d8a")
    ax.set_xticks(range(len(means)), [_label(row, r.factors) for _, row in means.iterrows()], fontsize=7)
    for role, style in (("upper", "--"), ("lower", ":")):
        if role in r.references:
            ax.axhline(r.references[role][0], color="#8a2f2f", linestyle=style, label=f"{role} reference")
    if r.references:
        ax.legend(fontsize=8, loc="upper right")
    ax.set_ylabel(f"{r.question} (mean, 95% CI)")
    ax.set_title(f"{r.task}: {r.question} ({len(r.participants)} participants)", fontsize=10)
    return _save(plt, fig, path)


def rating_boxes(r: RatingResult, path: Path) -> Path:
    """Participants' mean ratings per level of the two factors with the fewest levels (Fig. 11)."""
    subj = r.subject_means
    by = sorted(r.factors, key=lambda f: subj[f].nunique())[:2]
    groups = subj.groupby(["participant"] + by).rating.mean().reset_index().groupby(by)
    plt, fig, ax = _figure(max(4.5, 0.9 * groups.ngroups + 1.5), 4.0)
    labels, data = zip(*[(" / ".join(map(str, k if isinstance(k, tuple) else (k,))), g.rating.to_numpy()) for k, g in groups])
    ax.boxplot(data)
    ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=8, rotation=20)
    ax.set_ylabel(f"{r.question} (participant means)")
    ax.set_title(f"{r.task}: {r.question} by {' x '.join(by)}", fontsize=10)
    return _save(plt, fig, path)


def confusion_matrices(results: list[MatchingResult], path: Path) -> Path:
    """Counts of target (rows) against chosen (columns), one panel per matching task (Fig. 13)."""
    plt, fig, axes = _figure(3.3 * len(results), 3.4, panels=len(results))
    for ax, m in zip(axes if len(results) > 1 else [axes], results):
        c = m.confusion
        ax.imshow(c.to_numpy(), cmap="Blues", vmin=0)
        for i in range(c.shape[0]):
            for j in range(c.shape[1]):
                ax.text(j, i, int(c.iat[i, j]), ha="center", va="center", fontsize=9)
        ax.set_xticks(range(c.shape[1]), c.columns, fontsize=7, rotation=30)
        ax.set_yticks(range(c.shape[0]), c.index, fontsize=7)
        ax.set_xlabel("chosen", fontsize=8)
        ax.set_ylabel("target", fontsize=8)
        ax.set_title(f"{m.task}\n{m.correct_pct:.1f}% correct", fontsize=8)
    return _save(plt, fig, path)


def recognition_rates(results: list[MatchingResult], path: Path) -> Path:
    """Percent correct per target level, one line per matching task (Fig. 14)."""
    plt, fig, ax = _figure(6.0, 3.8)
    for m in results:
        levels = list(m.per_level_pct)
        ax.plot(levels, [m.per_level_pct[k] for k in levels], marker="o", label=m.task)
    ax.set_ylim(0, 100)
    ax.set_ylabel("recognition rate (%)")
    ax.legend(fontsize=7)
    ax.set_title("Matching: recognition rate per target", fontsize=10)
    return _save(plt, fig, path)


def draw_all(a: Analysis, folder: Path) -> list[Path]:
    """Every figure of an analysis, as PNG files in ``folder``."""
    out = []
    for r in a.ratings:
        stem = f"{r.task}-{r.question}"
        out.append(rating_bars(r, folder / f"{stem}-means.png"))
        if r.factors != ["stimulus"] and r.anova is not None:
            out.append(rating_boxes(r, folder / f"{stem}-boxes.png"))
    if a.matching:
        out.append(confusion_matrices(a.matching, folder / "matching-confusion.png"))
        out.append(recognition_rates(a.matching, folder / "matching-recognition.png"))
    return out
