"""Evaluation of interpolators: measures, floors, folds on uneven datasets, paired ratios, the command."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from hapticfx.data.bank import ProfileBank
from hapticfx.data.build import build_dataset
from hapticfx.data.dataset import open_dataset
from hapticfx.data.toy import toy_recordings
from hapticfx.errors import DatasetError, EffectError
from hapticfx.evaluation import measures
from hapticfx.processing import likeness
from hapticfx.evaluation.folds import looo_rounds, lovo_rounds, paper_rounds
from hapticfx.evaluation.report import markdown, summarise
from hapticfx.evaluation.runner import methods_from, run_evaluation
from hapticfx.objects import PAPER_OBJECTS

META = dict(name="uneven", rate_hz=1000.0, sensor={"model": "synthetic"}, provenance={"source": "test"})


@pytest.fixture(scope="module")
def uneven(tmp_path_factory):
    """Two objects recorded at different velocities, different numbers of them, different drop counts."""
    recs = [toy_recordings(PAPER_OBJECTS["wood-beam"], [2.0, 2.6, 3.3, 4.1], drops=5, seed=1),
            toy_recordings(PAPER_OBJECTS["steel-plate"], [2.2, 3.0, 3.5, 3.9, 4.6, 5.0], drops=7, seed=2)]
    return open_dataset(build_dataset(tmp_path_factory.mktemp("ev") / "uneven", recs, **META))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_measures_on_known_signals(dtype):
    t = np.arange(500) / 1000.0
    x = (np.sin(2 * np.pi * 100 * t) * np.exp(-10 * t)).astype(dtype)
    assert likeness.rmse(x, x) == 0.0 and likeness.log_spectral_distance(x, x) == 0.0
    assert np.isclose(likeness.rmse(x, 0 * x), np.sqrt(np.mean(x.astype(np.float64) ** 2)))
    assert np.isclose(likeness.peak_error_db(0.5 * x, x), 20 * np.log10(0.5))
    # a gain of 2 moves every bin by 6.02 dB where the spectrum stands well above the -60 dB floor
    noise = np.random.default_rng(1).standard_normal(500).astype(dtype)
    assert np.isclose(likeness.log_spectral_distance(2 * noise, noise), 20 * np.log10(2), atol=0.05)
    blurred = np.convolve(x, np.ones(9) / 9, mode="same")
    assert likeness.log_spectral_distance(blurred, x) > 3.0 and likeness.peak_error_db(blurred, x) < 0
    assert likeness.log_spectral_distance(np.zeros(500), np.zeros(500)) == 0.0
    with pytest.raises(Exception, match="non-finite"):
        likeness.rmse(x * np.nan, x)


def test_floors_of_identical_drops_are_zero_and_grow_with_spread():
    rng = np.random.default_rng(0)
    base = rng.standard_normal(200)
    same = np.stack([base] * 5)
    assert measures.floors(same, 2)["drop_to_drop_rmse"] == 0.0
    spread = base + 0.3 * rng.standard_normal((5, 200))
    f = measures.floors(spread, 0)
    assert 0.3 < f["drop_to_drop_rmse"] < 0.6 and f["mean_of_others_rmse"] < f["drop_to_drop_rmse"]
    assert measures.floors(spread[:1], 0) == {}


def test_floor_of_the_drop_mean_is_its_sampling_error():
    rng = np.random.default_rng(4)
    base = rng.standard_normal(300)
    assert likeness.mean_sampling_rmse(np.stack([base] * 6)) == 0.0  # a noiseless set: floor 0
    f = measures.floors(np.stack([base] * 6), 1)
    assert f["mean_sampling_rmse"] == 0.0 and f["drop_pairs_lsd_db"] == 0.0 and f["mean_of_others_lsd_db"] < 1e-9
    # D drops with iid noise sigma: the mean's error is sigma / sqrt(D), and the estimate says so
    for d in (3, 10):
        drops = base + 0.2 * rng.standard_normal((d, 300))
        assert np.isclose(likeness.mean_sampling_rmse(drops), 0.2 / np.sqrt(d), rtol=0.15)
        truth_mean = np.mean([likeness.rmse(base, (base + 0.2 * rng.standard_normal((d, 300))).mean(axis=0))
                              for _ in range(200)])
        assert np.isclose(truth_mean, 0.2 / np.sqrt(d), rtol=0.05)  # what an oracle scores against the mean


def test_the_drop_mean_loses_the_detail_each_drop_has_on_the_spectral_measure():
    """Drops that share a slow pulse and differ in their fine detail: the mean of the others keeps the pulse and
    loses most of the detail, so against each drop it is nearer in RMSE than another drop and further in LSD."""
    rng = np.random.default_rng(7)
    t = np.arange(500) / 1000.0
    pulse = np.exp(-((t - 0.1) / 0.01) ** 2)
    drops = pulse + 0.05 * rng.standard_normal((10, 500))
    f = measures.floors(drops, 0)
    direct = np.mean([likeness.log_spectral_distance(np.delete(drops, j, axis=0).mean(axis=0), drops[j])
                      for j in range(10)])
    assert np.isclose(f["mean_of_others_lsd_db"], direct, rtol=1e-12)
    assert f["mean_of_others_rmse"] < f["drop_to_drop_rmse"]
    assert f["mean_of_others_lsd_db"] > f["drop_pairs_lsd_db"]
    pairs = measures.drop_pairs(drops, rate_hz=1000.0)
    assert 0.0 <= pairs["mean_of_others_stsim"] <= 1.0 and 0.0 <= pairs["mean_of_others_spqi"] <= 1.0


def test_gap_share_is_0_for_linear_1_at_the_floor_and_undefined_without_a_gap():
    from hapticfx.evaluation.report import gap_share

    rng = np.random.default_rng(0)
    lin = rng.uniform(1.0, 2.0, 30)
    floor = 0.6 * lin
    assert gap_share(lin, lin, floor, rng, 200) == (0.0, 0.0, 0.0)
    assert np.allclose(gap_share(floor, lin, floor, rng, 200), 1.0)
    half = gap_share(0.8 * lin, lin, floor, rng, 200)
    assert np.isclose(half[0], 0.5) and half[1] <= 0.5 <= half[2]
    assert np.isnan(gap_share(0.9 * lin, lin, 1.1 * lin, rng, 200)).all()  # floor worse than linear: no gap
    up = gap_share(lin + 0.1, lin, lin + 0.2, rng, 200, higher=True)  # ST-SIM-like: the ceiling above
    assert np.allclose(up, 0.5)


def test_lovo_predicts_every_interior_velocity_of_every_object_once(uneven):
    banks = {o: uneven.bank(o, "max-min") for o in uneven.objects}
    rounds = lovo_rounds(banks)
    assert len(rounds) == 4  # steel-plate has 4 interior velocities, wood-beam 2
    seen = [(f.object, f.velocity) for r in rounds for f in r.folds]
    expected = [(o, float(v)) for o, b in banks.items() for v in b.velocities[1:-1]]
    assert sorted(seen) == sorted(expected)
    with pytest.raises(DatasetError, match="needs an object recorded at 3 or more velocities"):
        lovo_rounds({"x": ProfileBank("x", "max-min", 1000.0, np.array([1.0, 2.0]), np.ones((2, 4)))})
    with pytest.raises(DatasetError, match=r"the paper protocol needs '[a-z-]*' recorded at 2.8.*use --protocol lovo"):
        paper_rounds(banks)


def test_looo_never_trains_on_the_object_it_predicts(uneven):
    banks = {o: uneven.bank(o, "max-min") for o in uneven.objects}
    rounds = looo_rounds(banks)
    assert len(rounds) == 4  # two per object: odd and even interior velocities
    seen = sorted((f.object, f.velocity) for r in rounds for f in r.folds)
    assert seen == sorted((o, float(v)) for o, b in banks.items() for v in b.velocities[1:-1])
    for r in rounds:
        (obj,) = {f.object for f in r.folds}
        assert r.targets[obj] == [] and all(r.targets[o] for o in banks if o != obj)
        idx = [banks[obj].index_of(f.velocity) for f in r.folds]
        assert all(b - a >= 2 for a, b in zip(idx, idx[1:]))  # every held-out velocity keeps both neighbours
    results = run_evaluation(uneven, "max-min", methods_from(["ensemble"]), protocol="looo", repeats=5,
                             echo=lambda m: None)
    assert len(results["methods"]["ensemble"]["folds"]) == 6 and results["methods"]["ensemble"]["error"] is None


def test_ensemble_chooses_its_trim_on_training_targets_only(uneven):
    from hapticfx.data.training import training_data
    from hapticfx.interpolators.ensemble import FALLBACK_TRIM, choose_trim

    data = training_data(uneven, "max-min", targets={o: [] for o in uneven.objects})
    assert choose_trim(data) == (FALLBACK_TRIM, {})
    one = training_data(uneven, "max-min", targets={"wood-beam": [2.6], "steel-plate": []})
    every = training_data(uneven, "max-min")
    assert choose_trim(one)[1] != choose_trim(every)[1]


def test_run_scores_every_fold_and_ratios_are_paired(uneven):
    rows = methods_from(["ensemble", "linear"])
    assert [r.row for r in rows] == ["linear", "ensemble"]
    results = run_evaluation(uneven, "max-min", rows, repeats=5, echo=lambda m: None)
    assert len(results["folds"]) == 6 and results["rounds"] == 4
    for row in results["methods"].values():
        assert row["error"] is None and len(row["folds"]) == 6
        for e in row["folds"]:
            assert all(np.isfinite(e[k]) for k in ("rmse", "rmse_drops", "lsd_db", "peak_db", "lsd_drops_db"))
    for f in results["folds"]:
        assert f["mean_of_others_rmse"] <= f["drop_to_drop_rmse"] + 1e-12
    summary = summarise(results, boot=500)
    lin = summary["methods"]["linear"]
    assert lin["rmse_ratio"] == (1.0, 1.0, 1.0) and lin["rmse_wins"] == 0
    ens = summary["methods"]["ensemble"]
    lo, mid, hi = ens["rmse_ratio"][1], ens["rmse_ratio"][0], ens["rmse_ratio"][2]
    assert lo <= mid <= hi
    mean_ratio = ens["rmse"] / lin["rmse"]
    assert np.isclose(mid, mean_ratio)  # folds are paired one to one: ratio of sums = ratio of means
    assert set(summary["objects"]) == {"wood-beam", "steel-plate"}
    json.dumps(results)
    for e in results["methods"]["linear"]["folds"]:
        assert all(np.isfinite(e[k]) for k in ("rmse_mean", "stsim", "spqi")) and 0 <= e["stsim"] <= 1.5
    # an oracle at the floors captures the whole gap; linear none of it
    floors = {(f["object"], f["velocity"]): f for f in results["folds"]}
    oracle = [{**e, "rmse": floors[(e["object"], e["velocity"])]["mean_of_others_rmse"],
               "rmse_mean": floors[(e["object"], e["velocity"])]["mean_sampling_rmse"]}
              for e in results["methods"]["linear"]["folds"]]
    results["methods"]["oracle"] = {**results["methods"]["linear"], "folds": oracle}
    summary = summarise(results, boot=300)
    assert summary["methods"]["linear"]["rmse_mean_share"] == (0.0, 0.0, 0.0)
    assert np.allclose(summary["methods"]["oracle"]["rmse_share"], 1.0)
    assert np.allclose(summary["methods"]["oracle"]["rmse_mean_share"], 1.0)


def test_a_method_that_cannot_run_is_reported_not_fatal(tiny_dataset):
    ds = open_dataset(tiny_dataset)
    results = run_evaluation(ds, "max-min", methods_from(["ensemble"]), repeats=5, echo=lambda m: None)
    assert results["methods"]["ensemble"]["error"].startswith("the ensemble interpolator needs every recorded drop")
    assert len(results["methods"]["linear"]["folds"]) == len(results["folds"])
    assert "rmse_drops" not in results["methods"]["linear"]["folds"][0]  # no raw drops: no drop measures
    summary = summarise(results, boot=100)
    assert "error" in summary["methods"]["ensemble"]


def test_a_rows_fill_is_reported_beside_its_texture_each_round(uneven, tmp_path):
    cfg = tmp_path / "rows.yaml"
    cfg.write_text("ew-fill: {interpolator: ensemble-warp, options: {fill: 0.5}}\n")
    results = run_evaluation(uneven, "max-min", methods_from(["ew-fill"], cfg), repeats=5, echo=lambda m: None)
    summary = summarise(results, boot=100)
    assert summary["methods"]["ew-fill"]["fills"] == [0.5] * results["rounds"]
    assert "fills" not in summary["methods"]["linear"]
    run_time = markdown(results, summary).split("### Run time")[1].split("###")[0]
    cells = next(line for line in run_time.splitlines() if line.startswith("| ew-fill |")).split(" | ")[3]
    assert [c.split(" fill ")[1] for c in cells.split(", ")] == ["0.5"] * results["rounds"]


def test_unknown_methods_and_config_keys_are_refused(tmp_path):
    with pytest.raises(EffectError, match="unknown method 'nope': no interpolator 'nope'"):
        methods_from(["nope"])
    cfg = tmp_path / "rows.yaml"
    cfg.write_text("lin2: {interpolator: linear, epoch: 3}\n")
    with pytest.raises(EffectError, match=r"rows.yaml: lin2: unknown key\(s\) epoch"):
        methods_from(["lin2"], cfg)


def test_the_command_writes_tables_json_and_figures(uneven, tmp_path):
    out = tmp_path / "bench"
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "interpolators", "--dataset", str(uneven.path),
                        "--repeats", "5", "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for name in ("tables.md", "results.json", "error_vs_runtime.png", "examples.png"):
        assert (out / name).is_file(), name
    assert "### RMSE vs representative (g)" in r.stdout and "floor: mean of the other drops" in r.stdout
    assert "| ensemble-warp |" in r.stdout and "| ensemble |" in r.stdout  # default rows: the shipped one and ensemble
    run_time = r.stdout.split("### Run time")[1].split("###")[0]
    warp_row = next(line for line in run_time.splitlines() if line.startswith("| ensemble-warp |")).split(" | ")
    assert "| texture per round |" in run_time and len(warp_row[3].split(", ")) == 4  # the texture each round chose
    assert all(float(t) in (0.0, 0.2, 0.4, 0.6, 0.8) for t in warp_row[3].split(", "))
    assert "[4/4]" in r.stderr
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "interpolators", "--dataset", str(uneven.path),
                        "--protocol", "paper"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2 and "the paper protocol needs" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "bench-interpolators").exists()  # a refused run leaves no output folder behind


def test_protocol_criteria_and_table(uneven):
    from hapticfx.evaluation.protocol import DATASETS, criteria, table

    good = {"rmse_mean_ratio": (0.5, 0.4, 0.6), "rmse_mean_share": (0.8, 0.7, 0.9), "rmse_share": (0.61, 0.3, 0.9),
            "lsd_drops_db_ratio": (0.99, 0.9, 1.1), "stsim_ratio": (1.01, 0.9, 1.1), "spqi_ratio": (1.0, 0.9, 1.1)}
    assert criteria(good) == {"mean": True, "rep": True, "LSD": True, "perceptual": True, "all": True}
    assert not criteria({**good, "rmse_mean_ratio": (0.5, 0.4, 1.01)})["mean"]  # CI must exclude 1
    assert not criteria({**good, "rmse_share": (0.59, 0.5, 0.7)})["rep"]
    assert not criteria({**good, "rmse_share": (float("nan"),) * 3})["rep"]
    assert not criteria({**good, "spqi_ratio": (0.99, 0.9, 1.1)})["perceptual"]
    assert not criteria({**good, "lsd_drops_db_ratio": (1.01, 0.9, 1.1)})["all"]
    from hapticfx.evaluation.heldout import HELDOUT

    assert DATASETS[:2] == (("builtin:helmet-drops", "lovo"), ("builtin:helmet-drops", "looo"))
    assert DATASETS[2:] == tuple((f"heldout:{name}", "lovo") for name in HELDOUT)  # every held-out set, none twice
    assert len(HELDOUT) >= 9
    results = run_evaluation(uneven, "max-min", methods_from(["ensemble"]), repeats=5, max_rounds=2,
                             echo=lambda m: None)
    assert results["rounds"] == 2 and len(results["folds"]) == 3  # rounds 1 (both objects) and 4 (steel only)
    md = table(results, summarise(results, boot=100))
    assert "3 folds (2 rounds)" in md and "| linear |" in md and "baseline" in md
    assert md.count("| ensemble |") == 1
    from hapticfx.evaluation.protocol import combined

    summary = summarise(results, boot=100)
    both = combined([(results, summary)] * 2)
    assert both.count("| ensemble |") == 2 and "| linear |" not in both
    # what the drop mean itself scores, per dataset: the floors over linear's mean score
    from hapticfx.evaluation.protocol import ideal

    got = ideal(summary)
    lin = summary["methods"]["linear"]
    assert got["lsd_drops_db"] == summary["floors"]["mean_of_others_lsd_db"] / lin["lsd_drops_db"]
    assert set(got) == {"lsd_drops_db", "stsim", "spqi"}
    assert both.count(f"| {got['lsd_drops_db']:.3f} | {got['stsim']:.3f} | {got['spqi']:.3f} |") == 2
    assert "The drop mean itself against each drop / linear: LSD" in md
    # and what a recorded drop scores against the others, beside it
    from hapticfx.evaluation.protocol import RECORDED

    real = ideal(summary, RECORDED)
    assert real["spqi"] == summary["floors"]["drop_to_drop_spqi"] / lin["spqi"] and set(real) == set(got)
    assert f"A recorded drop against the others / linear: LSD vs drops {real['lsd_drops_db']:.3f}" in md
    row = f"| {got['spqi']:.3f} | {real['lsd_drops_db']:.3f} | {real['stsim']:.3f} | {real['spqi']:.3f} |"
    assert both.count(row) == 2


def test_generalisation_takes_no_dataset(tmp_path):
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "interpolators", "--protocol", "generalisation",
                        "--dataset", "x", "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode == 2 and "runs its fixed list of datasets; drop --dataset" in r.stderr


def _comparable(results: dict) -> dict:
    """Results without what a rerun measures afresh (fit and run times) and how many processes ran it."""
    out = json.loads(json.dumps(results))
    out.pop("processes")
    for row in out["methods"].values():
        row.pop("latency_ms", None), row.pop("table_latency_ms", None)
        for fit in row["fits"]:
            fit.pop("fit_s")
    return out


def test_a_stopped_run_resumes_where_it_stopped(uneven):
    rows = methods_from(["ensemble"])
    saved = []
    full = run_evaluation(uneven, "max-min", rows, repeats=5, echo=lambda m: None,
                          on_round=lambda r: saved.append(json.loads(json.dumps(r))))
    assert [s["rounds"] for s in saved] == [1, 2, 3, 4] and saved[-1]["rounds_planned"] == 4
    said = []
    resumed = run_evaluation(uneven, "max-min", rows, repeats=5, previous=saved[1], echo=said.append)
    assert sum("kept from the earlier run" in m for m in said) == 2
    assert sum(m.strip() == "ensemble: fitting" for m in said) == 2  # only rounds 3 and 4 were fitted
    assert _comparable(resumed) == _comparable(full)
    assert "latency_ms" in resumed["methods"]["ensemble"]  # kept from the earlier run's first round
    again = run_evaluation(uneven, "max-min", rows, repeats=5, previous=json.loads(json.dumps(full)),
                           echo=said.append)
    assert _comparable(again) == _comparable(full)


def test_a_resumed_run_refuses_other_rows_protocols_and_drops(uneven):
    rows = methods_from(["ensemble"])
    earlier = json.loads(json.dumps(run_evaluation(uneven, "max-min", rows, repeats=5, max_rounds=2,
                                                   echo=lambda m: None)))
    quiet = dict(repeats=5, echo=lambda m: None)
    other = [rows[0], rows[1].__class__("ensemble", "ensemble", {"trims": [0.1]})]
    with pytest.raises(EffectError, match="rows differ from these in: ensemble"):
        run_evaluation(uneven, "max-min", other, previous=earlier, **quiet)
    with pytest.raises(EffectError, match="rows differ from these in: ensemble-warp"):
        run_evaluation(uneven, "max-min", methods_from(["ensemble", "ensemble-warp"]), previous=earlier, **quiet)
    with pytest.raises(EffectError, match="the earlier run has protocol 'lovo', this one 'looo'"):
        run_evaluation(uneven, "max-min", rows, protocol="looo", previous=earlier, **quiet)
    changed = json.loads(json.dumps(earlier))
    fold = changed["folds"][0]
    fold["mean_of_others_rmse"] *= 1.001
    with pytest.raises(EffectError, match=f"the drops of {fold['object']} at {fold['velocity']:g} m/s are not those"):
        run_evaluation(uneven, "max-min", rows, previous=changed, **quiet)
    old = {k: v for k, v in earlier.items() if k != "hapticfx"}
    with pytest.raises(EffectError, match="written by a hapticfx that cannot resume it"):
        run_evaluation(uneven, "max-min", rows, previous=old, **quiet)
    # the earlier run's 2 rounds (1 and 4) are kept in a run of every round
    said = []
    run_evaluation(uneven, "max-min", rows, repeats=5, previous=earlier, echo=said.append)
    assert [m.split(":")[0] for m in said if "kept from the earlier run" in m] == ["[1/4] interior velocity 1 of each object",
                                                                                     "[4/4] interior velocity 4 of each object"]


def test_rounds_fitted_side_by_side_score_as_a_serial_run_does(uneven):
    rows = methods_from(["ensemble", "ensemble-warp"])
    serial = run_evaluation(uneven, "max-min", rows, repeats=5, echo=lambda m: None)
    saved, said = [], []
    side = run_evaluation(uneven, "max-min", rows, repeats=5, jobs=2, echo=said.append,
                          on_round=lambda r: saved.append(json.loads(json.dumps(r))))
    assert _comparable(side) == _comparable(serial)
    assert all("latency_ms" in row for row in side["methods"].values())  # timed once, in one of the processes
    assert "4 rounds in 2 processes" in said
    assert (serial["processes"], side["processes"]) == (1, 2)
    assert "Rounds ran in 2 processes side by side" in markdown(side, summarise(side))
    assert "side by side" not in markdown(serial, summarise(serial))
    # saved after every round, each save holding only finished rounds, in round order
    assert [s["rounds"] for s in saved] == [1, 2, 3, 4]
    for s in saved:
        finished = {f["round"] for f in s["folds"]}
        assert len(finished) == s["rounds"]
        assert {x["round"] for row in s["methods"].values() for x in row["fits"]} == finished
        assert [f["round"] for f in s["folds"]] == sorted(f["round"] for f in s["folds"])
    # a side-by-side run stopped after its first saved round resumes into the same results
    resumed = run_evaluation(uneven, "max-min", rows, repeats=5, jobs=2, previous=saved[0], echo=lambda m: None)
    assert _comparable(resumed) == _comparable(serial)


def test_the_command_resumes_and_refuses_a_corrupt_results_file(uneven, tmp_path):
    out = tmp_path / "bench"
    cmd = [sys.executable, "-m", "hapticfx", "bench", "interpolators", "--dataset", str(uneven.path),
           "--methods", "ensemble", "--repeats", "5", "--out", str(out), "--resume"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "no earlier run to resume; running every round" in r.stderr
    first = json.loads((out / "results.json").read_text())
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stderr.count("kept from the earlier run") == 4 and "fitting" not in r.stderr
    assert json.loads((out / "results.json").read_text())["summary"]["methods"]["ensemble"]["rmse_ratio"] \
        == first["summary"]["methods"]["ensemble"]["rmse_ratio"]
    (out / "results.json").write_text('{"results": {"folds": []')
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"{out / 'results.json'}: cannot resume from it (JSONDecodeError" in r.stderr
