"""`study analyze`: it finds a known effect in simulated data as often as the design's power says, finds
none at the nominal 5 % when there is none, and its ANOVA table is statsmodels' on the same data."""

from __future__ import annotations

import dataclasses
import json
import shutil

import numpy as np
import pytest

pd = pytest.importorskip("pandas")
pytest.importorskip("statsmodels")

from scipy import stats  # noqa: E402

from hapticfx.cli import main  # noqa: E402
from hapticfx.study.analysis import FACTOR, analyse_ratings  # noqa: E402
from hapticfx.study.schedule import build_schedule  # noqa: E402
from hapticfx.study.simulate import SimulatedParticipant  # noqa: E402
from hapticfx.study.spec import load_study  # noqa: E402
from study_files import ANSWER_DAMAGE, damaged, small_study, write_study  # noqa: E402

N_PARTICIPANTS, NOISE_SD, SHIFT = 8, 10.0, 10.0


def _rating_study(tmp_path, shift: float):
    """Three data-driven/physics stimuli rated once per velocity (2 velocities); ``shift`` on one of them."""
    study = small_study()
    study["tasks"] = [{**study["tasks"][0], "stimuli": ["phys-brick", "dd-brick", "dd-steel"], "per_trial": "each",
                       "order": "random", "practice": 0, "break_every": 0}]
    study["simulate"] = {"noise_sd": NOISE_SD, "participant_sd": 5.0,
                         "effects": [{"when": {"method": "data-driven", "object": "steel"}, "shift": shift}]}
    return load_study(write_study(tmp_path, study, name=f"shift-{shift}.yaml"))


def _simulated_frame(study):
    """The simulated participants' ratings as tidy rows (what `tidy` makes of the results files)."""
    task = study.tasks[0]
    rows = []
    for p in range(1, N_PARTICIPANTS + 1):
        who = SimulatedParticipant(study, f"P{p:02d}")
        for trial in build_schedule(study, f"P{p:02d}"):
            rating = who.respond(trial, task, {})["ratings"]["realism"]
            rows.append({"participant": f"P{p:02d}", "task": task.name, "kind": "rating", "question": "realism",
                         "practice": False, "role": None, "stimulus": trial.cell, "rating": rating,
                         FACTOR + "stimulus_name": trial.cell})
    return pd.DataFrame(rows)


def _expected_power(shift: float) -> float:
    """Power of the one-way repeated-measures F test: noncentral F with the cell means' error variance."""
    k, n = 3, N_PARTICIPANTS
    effects = np.array([0.0, 0.0, shift])
    sigma2 = NOISE_SD**2 / 2  # each cell mean averages 2 velocities
    lam = n * np.sum((effects - effects.mean()) ** 2) / sigma2
    df1, df2 = k - 1, (n - 1) * (k - 1)
    return float(stats.ncf.sf(stats.f.ppf(0.95, df1, df2), df1, df2, lam))


def test_known_effect_found_at_the_expected_power_and_no_effect_at_five_percent(tmp_path):
    runs = 120
    rates = {}
    for shift in (0.0, SHIFT):
        hits, study = 0, _rating_study(tmp_path, shift)
        for seed in range(runs):  # one simulated study per seed: other orders, offsets and noise
            r = analyse_ratings(_simulated_frame(dataclasses.replace(study, seed=seed)), "realism", "realism", posthoc=False)
            hits += r.anova.loc["stimulus_name", "Pr > F"] < 0.05
        rates[shift] = hits / runs
    expected = {0.0: 0.05, SHIFT: _expected_power(SHIFT)}
    for shift, rate in rates.items():
        low, high = stats.binom.interval(0.999, runs, expected[shift])
        assert low / runs <= rate <= high / runs, (shift, rate, expected[shift])
    assert 0.6 < expected[SHIFT] < 0.9  # a design where the test can fail both ways
    print(f"rejection rate: no effect {rates[0.0]:.3f} (expected 0.05); shift {SHIFT}: {rates[SHIFT]:.3f} "
          f"(expected power {expected[SHIFT]:.3f}); {runs} simulated studies each")


def _cli(*args) -> int:
    with pytest.raises(SystemExit) as exit_:
        main(list(args))
    return exit_.value.code


def test_analyze_a_simulated_run_end_to_end(tmp_path, capsys):
    study = small_study(t0={"repetitions": 2, "per_trial": "each", "practice": 1})
    study["simulate"] = {"effects": [{"when": {"method": "data-driven"}, "shift": 25}], "noise_sd": 5}
    path = write_study(tmp_path, study)
    results = tmp_path / "results"
    assert _cli("study", "run", str(path), "--simulate", "--participants", "6", "--device", "memory", "--out", str(results)) == 0
    assert _cli("study", "analyze", str(results)) == 0
    out = capsys.readouterr().out
    folder = results / "analysis"
    names = {p.name for p in folder.iterdir()}
    assert {"trials.csv", "means.csv", "anova.csv", "pairwise.csv", "confusion.csv", "report.txt",
            "realism-realism-means.png", "realism-realism-boxes.png", "similarity-similarity-means.png",
            "matching-confusion.png", "matching-recognition.png"} <= names
    assert not [n for n in names if n.startswith(".")]  # nothing half-written left behind

    trials = pd.read_csv(folder / "trials.csv")
    answers = [json.loads(line) for p in sorted(results.glob("P*.jsonl")) for line in p.read_text().splitlines()
               if '"type": "answer"' in line]
    assert len(trials) == len(answers)  # one question per rating task here: one row per answer
    assert trials.simulated.all()  # each row says a simulated participant gave it
    # The ANOVA table is statsmodels' AnovaRM on the same answers, practice left out, repetitions averaged.
    from statsmodels.stats.anova import AnovaRM

    rows = [{"participant": a["participant"], "rating": a["response"]["ratings"]["realism"],
             **a["slots"][0]["factors"]} for a in answers if a["task"] == "realism" and not a["practice"]]
    library = AnovaRM(pd.DataFrame(rows), "rating", "participant", within=["method", "object"],
                      aggregate_func="mean").fit().anova_table
    ours = pd.read_csv(folder / "anova.csv", index_col="effect")
    ours = ours[(ours.task == "realism") & (ours.question == "realism")].drop(columns=["task", "question"])
    pd.testing.assert_frame_equal(ours, library, check_names=False, rtol=1e-9)
    assert library.loc["method", "Pr > F"] < 0.05 and "method: F(1, 5)" in out

    # confusion counts are the answers' target/chosen pairs
    confusion = pd.read_csv(folder / "confusion.csv")
    matched = [a for a in answers if a["kind"] == "matching"]
    assert confusion["count"].sum() == len(matched)
    correct = sum(a["correct"] for a in matched)
    assert f"match: {100 * correct / len(matched):.1f}% correct, chance 50% ({len(matched)} answers, 6 participants)" in out
    assert "6 simulated participants" in out


def test_analyze_refuses_a_folder_without_results(tmp_path, capsys):
    assert _cli("study", "analyze", str(tmp_path)) == 2
    assert capsys.readouterr().err.strip() == f"hapticfx: error: {tmp_path}: holds no results (no <participant>.jsonl files)"


@pytest.fixture(scope="module")
def simulated_results(tmp_path_factory):
    """A results folder with one simulated participant of the small study."""
    folder = tmp_path_factory.mktemp("simulated")
    results = folder / "results"
    assert _cli("study", "run", str(write_study(folder, small_study())), "--simulate", "--participants", "1",
                "--device", "memory", "--out", str(results)) == 0
    return results


@pytest.mark.parametrize("how", ["random bytes", "a list line", *ANSWER_DAMAGE])
def test_analyze_names_the_line_of_a_damaged_results_file(simulated_results, tmp_path, capsys, how):
    results = shutil.copytree(simulated_results, tmp_path / "results")
    expected = damaged(results / "P01.jsonl", how)
    capsys.readouterr()
    assert _cli("study", "analyze", str(results)) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"hapticfx: error: {results / 'P01.jsonl'}: {expected}") and err.count("\n") == 1, err
    assert not (results / "analysis").exists()


def test_analyze_needs_the_folders_copy_of_the_study_file(simulated_results, tmp_path, capsys):
    results = shutil.copytree(simulated_results, tmp_path / "results")
    (results / "study.yaml").unlink()
    assert _cli("study", "analyze", str(results)) == 2
    assert capsys.readouterr().err.strip() == \
        f"hapticfx: error: {results}: holds no study.yaml, the copy of the study file its answers are checked against"
