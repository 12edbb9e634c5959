"""PNG figures of a study's analysis, after the paper's Figs. 10-15 (matplotlib, imported when drawing).

Each ``*_figure`` function returns a matplotlib ``Figure`` (no pyplot state), so that a test can measure
what it draws; :func:`draw_all` saves them. Every title says who answered ("12 simulated participants").
"""

from __future__ import annotations

from pathlib import Path

from ..atomic import atomic_path
from .analysis import Analysis, MatchingResult, RatingResult

BAR, EDGE, REFERENCE, CHANCE = "#6a9fb5", "#2f5d8a", "#8a2f2f", "#555555"


def _figure(width: float, height: float, panels: int = 1):
    """A figure (constrained layout, Agg canvas) and its ``panels`` axes side by side."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, panels, squeeze=False)[0]
    return fig, list(axes)


def save(fig, path: Path, metadata: dict | None = None) -> Path:
    """Write ``fig`` as a PNG, whole or not at all."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", metadata=metadata)
    return path


def title(task: str, question: str) -> str:
    """``task: question``, or the one name when the question is named after its task."""
    return question if question == task else f"{task}: {question}"


def _condition(row, factors) -> str:
    return " / ".join(str(row[f]) for f in factors)


def rating_bars_figure(r: RatingResult, who: str):
    """Mean rating per condition with 95% confidence intervals (Figs. 10, 15 and 16), one horizontal bar each so
    that long condition names never overlap; reference lines for similarity."""
    means = r.means.sort_values(r.factors).reset_index(drop=True)
    fig, (ax,) = _figure(7.0, 1.3 + 0.28 * len(means))
    err = [means["mean"] - means.ci_low, means.ci_high - means["mean"]]
    ax.barh(range(len(means)), means["mean"], xerr=err, capsize=3, color=BAR, edgecolor=EDGE)
    ax.set_yticks(range(len(means)), [_condition(row, r.factors) for _, row in means.iterrows()], fontsize=8)
    ax.invert_yaxis()  # the first condition on top
    for role, style in (("upper", "--"), ("lower", ":")):
        if role in r.references:
            ax.axvline(r.references[role][0], color=REFERENCE, linestyle=style, label=f"{role} reference")
    if r.references:
        ax.legend(fontsize=7, loc="lower right")
    ax.set_xlabel(f"{r.question}: mean of participant means, 95% CI", fontsize=9)
    ax.set_title(f"{title(r.task, r.question)} ({who})", fontsize=10)
    return fig


def rating_boxes_figure(r: RatingResult, who: str):
    """Participants' mean ratings per level of the two factors with the fewest levels (Fig. 11)."""
    subj = r.subject_means
    by = sorted(r.factors, key=lambda f: subj[f].nunique())[:2]
    groups = subj.groupby(["participant"] + by).rating.mean().reset_index().groupby(by)
    fig, (ax,) = _figure(max(4.5, 1.4 * groups.ngroups + 1.2), 4.0)
    labels, data = zip(*[("\n".join(map(str, k if isinstance(k, tuple) else (k,))), g.rating.to_numpy()) for k, g in groups])
    ax.boxplot(data)
    ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=8)
    ax.set_ylabel(f"{r.question} (participant means)", fontsize=9)
    ax.set_title(f"{title(r.task, r.question)} by {' x '.join(by)} ({who})", fontsize=10)
    return fig


def confusion_figure(results: list[MatchingResult], who: str):
    """Percent of each target's answers (rows) that chose each level (columns), one panel per matching task, on
    one colour scale with its colour bar (Fig. 13); the correct cells are framed."""
    from matplotlib.patches import Rectangle

    fig, axes = _figure(2.9 * len(results) + 1.0, 3.6, panels=len(results))
    image = None
    for ax, m in zip(axes, results):
        c = m.confusion
        pct = 100.0 * c.div(c.sum(axis=1).where(c.sum(axis=1) > 0, 1), axis=0)
        image = ax.imshow(pct.to_numpy(), cmap="Blues", vmin=0, vmax=100)
        for i in range(c.shape[0]):
            for j in range(c.shape[1]):
                ax.text(j, i, f"{pct.iat[i, j]:.0f}", ha="center", va="center", fontsize=8,
                        color="white" if pct.iat[i, j] > 55 else "black")
                if c.index[i] == c.columns[j]:
                    ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, edgecolor="black", linewidth=1.5))
        ax.set_xticks(range(c.shape[1]), c.columns, fontsize=7, rotation=90)
        ax.set_yticks(range(c.shape[0]), c.index, fontsize=7)
        ax.set_xlabel("chosen", fontsize=8)
        ax.set_ylabel("target", fontsize=8)
        ax.set_title(f"{m.task}\n{m.correct_pct:.1f}% correct (chance {m.chance_pct:.0f}%)", fontsize=8)
    fig.colorbar(image, ax=axes, shrink=0.8, label="% of the target's answers")
    fig.suptitle(f"Matching: confusion matrices ({who}); framed: the correct answer", fontsize=10)
    return fig


def recognition_figure(results: list[MatchingResult], who: str):
    """Percent correct per target level, one line per matching task, and the chance level (Fig. 14)."""
    fig, (ax,) = _figure(7.0, 4.0)
    for m in results:
        levels = list(m.per_level_pct)
        ax.plot(levels, [m.per_level_pct[k] for k in levels], marker="o", label=m.task)
    for chance in sorted({round(m.chance_pct, 6) for m in results}):
        ax.axhline(chance, color=CHANCE, linestyle=":", label=f"chance ({chance:.0f}%)")
    ax.set_ylim(0, 100)
    ax.set_ylabel("recognition rate (%)", fontsize=9)
    ax.set_xlabel("target", fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(f"Matching: recognition rate per target ({who})", fontsize=10)
    return fig


def figures(a: Analysis) -> dict[str, object]:
    """Every figure of an analysis by file name."""
    out = {}
    for r in a.ratings:
        stem = f"{r.task}-{r.question}"
        out[f"{stem}-means.png"] = rating_bars_figure(r, a.who)
        if r.factors != ["stimulus"] and r.anova is not None:
            out[f"{stem}-boxes.png"] = rating_boxes_figure(r, a.who)
    if a.matching:
        out["matching-confusion.png"] = confusion_figure(a.matching, a.who)
        out["matching-recognition.png"] = recognition_figure(a.matching, a.who)
    return out


def draw_all(a: Analysis, folder: Path) -> list[Path]:
    """Every figure of an analysis, as PNG files in ``folder``."""
    return [save(fig, folder / name) for name, fig in figures(a).items()]
