"""Analysis of a results folder: tidy trials, means with confidence intervals, repeated-measures ANOVA,
Holm-corrected pairwise tests and confusion matrices.

The statistics are the libraries': statsmodels' ``AnovaRM`` and
``multipletests(method="holm")``, scipy's paired t-test and t interval. pandas,
statsmodels and scipy are imported inside the functions (``pip install
hapticfx[study]``), so that nothing else in hapticfx pays for them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

from ..errors import StudyError

FACTOR = "factor_"  # prefix of the stimulus factor columns of the tidy table


def _pandas():
    try:
        import pandas as pd
        import statsmodels  # noqa: F401  (checked here so the error names the extra once)
    except ImportError as exc:
        raise StudyError(f"study analyze needs pandas and statsmodels: pip install 'hapticfx[study]' ({exc})") from None
    return pd


def tidy(records: dict[str, list[dict]]):
    """One row per answer and question (ratings) or per answer (matching), practice included."""
    pd = _pandas()
    rows = []
    for participant, recs in records.items():
        simulated = False
        for r in recs:
            if r.get("type") == "session":  # the answers that follow were given in this session
                simulated = bool(r.get("simulated"))
            if r.get("type") != "answer":
                continue
            slots = {s["stimulus"]: s for s in r["slots"]}
            base = {"participant": participant, "session": r["session"], "trial": r["trial"], "task": r["task"],
                    "kind": r["kind"], "cell": r["cell"], "role": r["role"], "practice": r["practice"],
                    "number": r["number"], "repetition": r["repetition"], "velocity": r["velocity"],
                    "response_time_s": r["response_time_s"], "answered_at": r["answered_at"], "simulated": simulated}
            first = r["cell"].split("|")[0]  # the stimulus a cell is about: a rated one, a target, a pair's first
            base["stimulus"] = first
            base["stimulus_b"] = r["cell"].split("|")[1] if r["kind"] == "similarity" else None
            base.update({FACTOR + f: level for f, level in slots[first]["factors"].items()})
            if r["kind"] == "matching":
                chosen = next(s for s in r["slots"] if s["stimulus"] == r["chosen_stimulus"])
                rows.append({**base, "question": None, "rating": None, "choice": r["response"]["choice"],
                             "alternatives": len(r["slots"]) - 1,
                             "chosen_stimulus": r["chosen_stimulus"], "correct": r["correct"],
                             "target_level": slots[first]["factors"][r["match_by"]],
                             "chosen_level": chosen["factors"][r["match_by"]]})
            else:
                for q, value in r["response"]["ratings"].items():
                    rows.append({**base, "question": q, "rating": value})
    if not rows:
        raise StudyError("the results hold no answers yet")
    frame = pd.DataFrame(rows)
    return frame.sort_values(["participant", "trial", "question"], na_position="first").reset_index(drop=True)


@dataclass
class RatingResult:
    """One rating question of one task: cell means, the ANOVA table and the pairwise tests."""

    task: str
    question: str
    factors: list[str]
    participants: list[str]
    excluded: list[str]
    means: Any                 # DataFrame: cell levels, mean, sd, n, ci_low, ci_high
    subject_means: Any         # DataFrame: participant x cell means (what the ANOVA sees)
    anova: Any | None          # DataFrame: F Value, Num DF, Den DF, Pr > F (None with < 2 participants)
    pairwise: Any | None       # DataFrame: factor, a, b, mean_diff, t, p, p_holm, significant
    references: dict = field(default_factory=dict)  # similarity: upper/lower reference means


def _balanced(data, factors: list[str]) -> tuple[Any, list[str]]:
    """Drop factor levels that are not crossed with every level of the other factors (the paper drops the solenoid)."""
    excluded = []
    while True:
        cells = data[factors].drop_duplicates()
        full = 1
        for f in factors:
            full *= cells[f].nunique()
        if len(cells) == full:
            return data, excluded
        worst = None
        for f in factors:
            for level, group in cells.groupby(f):
                others = [g for g in factors if g != f]
                missing = 1
                for g in others:
                    missing *= cells[g].nunique()
                missing -= len(group)
                if missing and (worst is None or missing > worst[0]):
                    worst = (missing, f, level)
        _, f, level = worst
        excluded.append(f"{f.removeprefix(FACTOR)}={level}")
        data = data[data[f] != level]


def _ci(values):
    import numpy as np
    from scipy import stats

    n = len(values)
    mean = float(np.mean(values))
    if n < 2:
        return mean, float("nan"), n, float("nan"), float("nan")
    sd = float(np.std(values, ddof=1))
    low, high = stats.t.interval(0.95, n - 1, loc=mean, scale=stats.sem(values)) if sd > 0 else (mean, mean)
    return mean, sd, n, float(low), float(high)


def analyse_ratings(frame, task: str, question: str, *, posthoc: bool = True) -> RatingResult:
    """Repeated-measures ANOVA over the stimulus factors that vary in ``task`` (test pairs only for similarity).

    ``posthoc=False`` leaves out the pairwise tests (a power simulation needs only the ANOVA).
    """
    pd = _pandas()
    from scipy import stats
    from statsmodels.stats.anova import AnovaRM
    from statsmodels.stats.multitest import multipletests

    d = frame[(frame.task == task) & (frame.question == question) & ~frame.practice.astype(bool)]
    references = {}
    if (d.kind == "similarity").any():
        for role in ("upper", "lower"):
            ref = d[d.role == role].groupby("participant").rating.mean()
            if len(ref):
                references[role] = _ci(ref.to_numpy())
        d = d[d.role == "test"]
    factor_cols = [c for c in d.columns if c.startswith(FACTOR) and d[c].notna().all() and d[c].nunique() > 1]
    if not factor_cols:
        factor_cols = ["stimulus"]
    d, excluded = _balanced(d, factor_cols)
    n_cells = len(d[factor_cols].drop_duplicates())
    complete = d.groupby("participant")[factor_cols].apply(lambda g: len(g.drop_duplicates())) == n_cells
    dropped = sorted(complete.index[~complete])
    excluded += [f"participant {p} (missing conditions)" for p in dropped]
    d = d[d.participant.isin(complete.index[complete])]
    subject_means = d.groupby(["participant"] + factor_cols, as_index=False).rating.mean()
    rows = []
    for levels, g in subject_means.groupby(factor_cols):
        mean, sd, n, low, high = _ci(g.rating.to_numpy())
        rows.append({**dict(zip(factor_cols, levels if isinstance(levels, tuple) else (levels,))),
                     "mean": mean, "sd": sd, "n": n, "ci_low": low, "ci_high": high})
    means = pd.DataFrame(rows)
    participants = sorted(subject_means.participant.unique())
    anova = pairwise = None
    if len(participants) >= 2 and n_cells >= 2:
        anova = AnovaRM(d, depvar="rating", subject="participant", within=factor_cols, aggregate_func="mean").fit().anova_table
        anova.index = [i.replace(FACTOR, "") for i in anova.index]
        tests = []
        for f in factor_cols if posthoc else []:
            per_level = subject_means.groupby(["participant", f]).rating.mean().unstack(f)
            for a, b in combinations(sorted(per_level.columns), 2):
                t, p = stats.ttest_rel(per_level[a], per_level[b])
                tests.append({"factor": f.removeprefix(FACTOR), "a": a, "b": b,
                              "mean_diff": float((per_level[a] - per_level[b]).mean()), "t": float(t), "p": float(p)})
        pairwise = pd.DataFrame(tests, columns=["factor", "a", "b", "mean_diff", "t", "p"])
        if len(pairwise):
            # Holm within each factor's family of comparisons
            for f, idx in pairwise.groupby("factor").groups.items():
                reject, p_holm, _, _ = multipletests(pairwise.loc[idx, "p"], alpha=0.05, method="holm")
                pairwise.loc[idx, "p_holm"] = p_holm
                pairwise.loc[idx, "significant"] = reject
    means.columns = [c.removeprefix(FACTOR) for c in means.columns]
    return RatingResult(task, question, [f.removeprefix(FACTOR) for f in factor_cols], participants, excluded, means,
                        subject_means.rename(columns=lambda c: c.removeprefix(FACTOR)), anova, pairwise, references)


@dataclass
class MatchingResult:
    """One matching task: the confusion matrix (target level x chosen level) and percent correct."""

    task: str
    confusion: Any     # DataFrame of counts
    correct_pct: float
    per_level_pct: dict
    answers: int
    participants: int
    chance_pct: float  # percent correct by guessing: 100 / the number of comparisons, averaged over trials


def analyse_matching(frame, task: str) -> MatchingResult:
    pd = _pandas()
    d = frame[(frame.task == task) & ~frame.practice.astype(bool)]
    levels = sorted(set(d.target_level) | set(d.chosen_level))
    confusion = pd.crosstab(d.target_level, d.chosen_level).reindex(index=levels, columns=levels, fill_value=0)
    per_level = {lvl: 100.0 * float(d[d.target_level == lvl].correct.mean()) for lvl in levels if (d.target_level == lvl).any()}
    return MatchingResult(task, confusion, 100.0 * float(d.correct.mean()), per_level, len(d), d.participant.nunique(),
                          float((100.0 / d.alternatives).mean()))


@dataclass
class Analysis:
    """Everything ``study analyze`` reports on a results folder."""

    study: str
    trials: Any
    ratings: list[RatingResult]
    matching: list[MatchingResult]
    simulated: list[str] = field(default_factory=list)  # participants a simulated participant answered for (in part)

    @property
    def who(self) -> str:
        """``12 simulated participants``, ``12 participants, 3 simulated`` or ``12 participants``."""
        n, k = self.trials.participant.nunique(), len(self.simulated)
        return f"{n} simulated participants" if k and k == n else f"{n} participants" + (f", {k} simulated" if k else "")


def analyse(records: dict[str, list[dict]]) -> Analysis:
    """Analyse every task of a results folder's records."""
    frame = tidy(records)
    sessions = [r for recs in records.values() for r in recs if r.get("type") == "session"]
    ratings, matching = [], []
    for task in dict.fromkeys(frame.task):
        d = frame[frame.task == task]
        if d.kind.iloc[0] == "matching":
            matching.append(analyse_matching(frame, task))
        else:
            ratings += [analyse_ratings(frame, task, q) for q in dict.fromkeys(d.question)]
    simulated = sorted(frame.participant[frame.simulated].unique())
    return Analysis(sessions[0]["study"] if sessions else "?", frame, ratings, matching, simulated)


def _p(p: float) -> str:
    return "p < 0.0001" if p < 1e-4 else f"p = {p:.4f}"


def report(a: Analysis) -> str:
    """A short text report: per task, the ANOVA, significant pairwise differences, recognition rates."""
    main = a.trials[~a.trials.practice.astype(bool)]
    lines = [f"Study {a.study}: {a.who}, {main.trial.groupby(main.participant).nunique().sum()} "
             f"answered trials (practice excluded).", ""]
    for r in a.ratings:
        lines.append(f"{r.task} / {r.question}: {len(r.participants)} participants; factors {', '.join(r.factors)}"
                     + (f"; excluded {', '.join(r.excluded)}" if r.excluded else ""))
        for role, (mean, sd, n, low, high) in sorted(r.references.items(), reverse=True):
            lines.append(f"  {role} reference: {mean:.1f} (95% CI {low:.1f}-{high:.1f}, n={n})")
        best = r.means.sort_values("mean", ascending=False).iloc[0]
        worst = r.means.sort_values("mean").iloc[0]
        label = lambda row: " / ".join(str(row[f]) for f in r.factors)  # noqa: E731
        lines.append(f"  highest {label(best)}: {best['mean']:.1f}; lowest {label(worst)}: {worst['mean']:.1f}")
        if r.anova is None:
            lines.append("  (fewer than 2 complete participants: no ANOVA)")
            continue
        for effect, row in r.anova.iterrows():
            lines.append(f"  {effect}: F({row['Num DF']:.0f}, {row['Den DF']:.0f}) = {row['F Value']:.2f}, {_p(row['Pr > F'])}"
                         + (" *" if row["Pr > F"] < 0.05 else ""))
        sig = r.pairwise[r.pairwise.significant.astype(bool)] if len(r.pairwise) else r.pairwise
        for _, row in sig.iterrows():
            lines.append(f"  Holm: {row['factor']} {row['a']} vs {row['b']}: difference {row['mean_diff']:+.1f}, "
                         f"p_holm = {row['p_holm']:.4f}")
        if len(r.pairwise) and not len(sig):
            lines.append("  Holm: no pairwise difference is significant")
        lines.append("")
    for m in a.matching:
        per = ", ".join(f"{k} {v:.0f}%" for k, v in m.per_level_pct.items())
        lines.append(f"{m.task}: {m.correct_pct:.1f}% correct, chance {m.chance_pct:.0f}% ({m.answers} answers, "
                     f"{m.participants} participants); {per}")
    return "\n".join(lines).rstrip() + "\n"
