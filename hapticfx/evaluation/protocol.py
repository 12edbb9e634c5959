"""The generalisation protocol of issue 26: one fixed configuration on every dataset, judged by its criteria.

The same methods, options and training settings run, unchanged, on the set they were
designed on (``builtin:helmet-drops``, leave one velocity out), on every held-out set
(:mod:`hapticfx.evaluation.heldout`, leave one velocity out) and on the built-in set with
one object left out at a time. Each dataset gets one table; its pass/fail columns are the
"Done when" criteria, per method against linear:

- **mean**: >= 60 % of the gap between linear and the sampling-noise floor captured against
  the held-out drops' mean, and the 95 % CI of the RMSE ratio to linear below 1;
- **rep**: >= 60 % of the gap between linear and the "mean of the other drops" floor
  captured against the representative;
- **LSD**: log-spectral distance against every drop no worse than linear's (mean ratio <= 1);
- **perceptual**: ST-SIM and SPQI against every drop no worse than linear's (mean ratio >= 1).

Beside them, what the drop mean itself scores on the last two (the mean of the other drops
against each drop, :data:`IDEAL`): a prediction that met the RMSE floors would score that. Where
it is worse than linear, the spectral criteria and the RMSE criteria pull apart on that dataset.
And what a recorded drop scores (each drop against the others, :data:`RECORDED`): where it is worse
than linear, so are the recordings themselves.
"""

from __future__ import annotations

import numpy as np

from . import heldout

SHARE = 0.60
IDEAL = (("mean_of_others_lsd_db", "lsd_drops_db", "LSD vs drops"), ("mean_of_others_stsim", "stsim", "ST-SIM"),
         ("mean_of_others_spqi", "spqi", "SPQI"))  # (floor key, measure, label)
RECORDED = (("drop_pairs_lsd_db", "lsd_drops_db", "LSD vs drops"), ("drop_to_drop_stsim", "stsim", "ST-SIM"),
            ("drop_to_drop_spqi", "spqi", "SPQI"))
DATASETS = (  # (dataset reference, fold protocol): the built-in set both ways, then every held-out set
    ("builtin:helmet-drops", "lovo"),
    ("builtin:helmet-drops", "looo"),
    *((f"{heldout.PREFIX}{name}", "lovo") for name in heldout.HELDOUT),
)


def criteria(s: dict) -> dict[str, bool]:
    """Pass/fail of one method's summary (from :func:`hapticfx.evaluation.report.summarise`)."""
    def share_ok(key):
        t = s.get(f"{key}_share")
        return t is not None and np.isfinite(t[0]) and t[0] >= SHARE

    out = {
        "mean": share_ok("rmse_mean") and s["rmse_mean_ratio"][2] < 1.0,
        "rep": share_ok("rmse"),
        "LSD": "lsd_drops_db_ratio" in s and s["lsd_drops_db_ratio"][0] <= 1.0,
        "perceptual": all(f"{k}_ratio" in s and s[f"{k}_ratio"][0] >= 1.0 for k in ("stsim", "spqi")),
    }
    out["all"] = all(out.values())
    return out


def _ci(t) -> str:
    return "-" if t is None or not np.isfinite(t[0]) else f"{t[0]:.3f} [{t[1]:.3f}, {t[2]:.3f}]"


def _pct(t) -> str:
    return "-" if t is None or not np.isfinite(t[0]) else f"{100 * t[0]:.0f}% [{100 * t[1]:.0f}, {100 * t[2]:.0f}]"


def table(results: dict, summary: dict) -> str:
    """One dataset's table: the measures behind the criteria and the criteria as pass/fail."""
    lines = [f"#### `{results['dataset']}`, {results['protocol']}: {len(results['folds'])} folds "
             f"({results['rounds']} rounds)", "",
             "| method | RMSE vs drop mean / linear | gap share (mean) | RMSE vs rep / linear | gap share (rep) "
             "| LSD vs drops / linear | ST-SIM / linear | SPQI / linear | mean | rep | LSD | perceptual | all |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, s in summary["methods"].items():
        if "error" in s:
            lines.append(f"| {name} | not evaluated: {s['error']} |" + " |" * 11)
            continue
        c = criteria(s)
        marks = ["baseline"] * 5 if name == "linear" else ["pass" if c[k] else "fail"
                                                           for k in ("mean", "rep", "LSD", "perceptual", "all")]
        lines.append(f"| {name} | {_ci(s.get('rmse_mean_ratio'))} | {_pct(s.get('rmse_mean_share'))} "
                     f"| {_ci(s.get('rmse_ratio'))} | {_pct(s.get('rmse_share'))} | {_ci(s.get('lsd_drops_db_ratio'))} "
                     f"| {_ci(s.get('stsim_ratio'))} | {_ci(s.get('spqi_ratio'))} | "
                     + " | ".join(marks) + " |")
    fl = summary["floors"]
    if "mean_sampling_rmse" in fl and "mean_of_others_rmse" in fl:
        lin = summary["methods"]["linear"]
        lines += ["", f"Floors / linear: sampling error of the drops' mean "
                  f"{fl['mean_sampling_rmse'] / lin['rmse_mean']:.3f}, mean of the other drops "
                  f"{fl['mean_of_others_rmse'] / lin['rmse']:.3f}." + _ideal_text(summary)]
    return "\n".join(lines) + "\n"


def ideal(summary: dict, reference=IDEAL) -> dict[str, float]:
    """What a reference scores against each drop, over linear, per measure: by default the mean of the other drops
    (:data:`IDEAL`); :data:`RECORDED`, a recorded drop against the others."""
    fl, lin = summary["floors"], summary["methods"]["linear"]
    return {measure: fl[key] / lin[measure] for key, measure, _ in reference if key in fl and lin.get(measure)}


def _ideal_text(summary: dict) -> str:
    text = ""
    for reference, what in ((IDEAL, "The drop mean itself against each drop"),
                            (RECORDED, "A recorded drop against the others")):
        got = ideal(summary, reference)
        if got:
            text += f" {what} / linear: " + ", ".join(f"{label} {got[m]:.3f}" for _, m, label in reference
                                                      if m in got) + "."
    return text


def combined(runs: list[tuple[dict, dict]]) -> str:
    """Every dataset in one table (linear left out: it is the 1.000 every ratio is against)."""
    lines = ["| dataset (folds; floors / linear: drop mean, rep) | method | RMSE vs drop mean / linear | gap share "
             "(mean) | RMSE vs rep / linear | gap share (rep) | LSD vs drops / linear | ST-SIM / linear "
             "| SPQI / linear | mean, rep, LSD, perceptual | all |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for results, summary in runs:
        fl, lin = summary["floors"], summary["methods"]["linear"]
        floors = (f"{fl['mean_sampling_rmse'] / lin['rmse_mean']:.2f}, {fl['mean_of_others_rmse'] / lin['rmse']:.2f}"
                  if "mean_sampling_rmse" in fl and "mean_of_others_rmse" in fl else "-")
        where = f"`{results['dataset']}` {results['protocol']} ({len(results['folds'])}; {floors})"
        for name, s in summary["methods"].items():
            if name == "linear":
                continue
            if "error" in s:
                lines.append(f"| {where} | {name} | not evaluated: {s['error']} |" + " |" * 8)
                continue
            c = criteria(s)
            lines.append(f"| {where} | {name} | {_ci(s.get('rmse_mean_ratio'))} | {_pct(s.get('rmse_mean_share'))} "
                         f"| {_ci(s.get('rmse_ratio'))} | {_pct(s.get('rmse_share'))} "
                         f"| {_ci(s.get('lsd_drops_db_ratio'))} | {_ci(s.get('stsim_ratio'))} "
                         f"| {_ci(s.get('spqi_ratio'))} | "
                         + ", ".join("pass" if c[k] else "fail" for k in ("mean", "rep", "LSD", "perceptual"))
                         + f" | **{'pass' if c['all'] else 'fail'}** |")
    lines += ["", "What the drop mean itself scores against each drop, over linear (the mean of the other drops: a "
              "method at the RMSE floors scores about this; where it fails a criterion, that criterion and the RMSE "
              "criteria pull apart), and what a recorded drop scores against the others (where it fails one, so do "
              "the recordings):", "",
              "| dataset | " + " | ".join(f"{who}: {label} / linear" for who in ("drop mean", "a recorded drop")
                                          for _, _, label in IDEAL) + " |", "|---|---|---|---|---|---|---|"]
    for results, summary in runs:
        cells = []
        for reference in (IDEAL, RECORDED):
            got = ideal(summary, reference)
            cells += [f"{got[m]:.3f}" if m in got else "-" for _, m, _ in reference]
        lines.append(f"| `{results['dataset']}` {results['protocol']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
