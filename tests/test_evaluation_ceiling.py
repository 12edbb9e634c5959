"""bench ceiling: what a blend of two recorded neighbours could reach on the drop-mean measure, on dense sets."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from hapticfx.errors import DatasetError
from hapticfx.evaluation.ceiling import method_values, object_folds, share, split, summarise

N = 300


def _drops(shift_per_mps: float, *, drops: int, sigma: float, seed: int = 0, velocities=None):
    """A pulse and a bounce whose time moves ``shift_per_mps`` samples per m/s, plus white noise per drop."""
    v = np.linspace(2.0, 5.0, 7) if velocities is None else np.asarray(velocities)
    t = np.arange(N)
    clean = np.stack([(x / 5) * (np.exp(-0.5 * ((t - 20) / 3.0) ** 2)
                                 + 0.6 * np.exp(-0.5 * ((t - 80 - shift_per_mps * x) / 3.0) ** 2)) for x in v])
    noise = sigma * np.random.default_rng(seed).standard_normal((len(v), drops, N))
    return v, clean[:, None, :] + noise


def test_a_profile_that_changes_linearly_leaves_no_bias_and_noise_as_the_theory_says():
    # nothing moves, the amplitude is linear in v: the blend of the population means is exact, and what is left
    # is noise of known size: a mean of R drops has 1 floor squared, a representative (one drop) about R. With 100
    # population drops their own noise is 0.1 + 0.05 floors squared: the bias is near 0 only if it is taken out
    v, d = _drops(0.0, drops=110, sigma=0.05)
    folds = object_folds(split("flat", v, d, 10))
    row = summarise(folds)["all"]
    expected = np.mean([(1 - f.w) ** 2 + f.w ** 2 for f in folds])
    assert len(folds) == 5 and abs(row["bias"]) < 0.06
    assert row["recorded"] == pytest.approx(expected, rel=0.25)
    assert row["linear"] == pytest.approx(10 * expected, rel=0.25)
    assert row["ceiling"] == pytest.approx(1.0, abs=0.02)  # no bias: the floor is reachable
    assert 0.0 < row["with_recorded"] < row["ceiling"]


def test_a_moving_bounce_wants_the_warp_and_the_blend_alone_is_biased():
    v, d = _drops(6.0, drops=60, sigma=0.01)
    folds = object_folds(split("bouncer", v, d, 10))
    bias = {p: np.mean([f.bias[p] for f in folds]) for p in folds[0].bias}
    row = summarise(folds)["bouncer"]
    assert np.isfinite(row["penalty"]) and bias[float("inf")] > 10 * max(bias[row["penalty"]], 1.0)
    assert row["ceiling"] > 0.5 and row["ceiling"] >= row["with_recorded"]


def test_shares_follow_the_expected_rmse_and_a_method_at_linear_shares_nothing():
    v, d = _drops(0.0, drops=40, sigma=0.05, seed=2)
    folds = object_folds(split("flat", v, d, 10))
    assert share(folds, [f.linear for f in folds]) == pytest.approx(0.0, abs=1e-12)
    assert share(folds, [0.0] * len(folds)) == pytest.approx(1.0, abs=1e-12)
    assert share(folds, [-3.0] * len(folds)) == pytest.approx(1.0, abs=1e-12)  # noise-corrected below 0: clipped


def test_silence_and_identical_drops_give_no_folds_not_nan():
    v = np.linspace(2.0, 4.0, 5)
    assert object_folds(split("quiet", v, np.zeros((5, 20, N)), 10)) == []


def test_a_method_is_fitted_on_the_recorded_drops_alone_and_scored_on_the_same_scale():
    # two objects at their own velocities; linear through the bench's path equals the folds' own linear, and
    # ensemble-warp, which averages the recorded drops, lands between linear and the ceiling (below the recorded
    # means' morph: on these white-noise drops it keeps a share of their fine detail, its texture)
    v1, d1 = _drops(6.0, drops=40, sigma=0.03, seed=4)
    v2, d2 = _drops(0.0, drops=40, sigma=0.03, seed=5, velocities=[2.2, 2.9, 3.3, 4.1, 4.6, 5.4])
    splits = {"a": split("a", v1, d1, 10), "b": split("b", v2, d2, 10)}
    folds = [f for o in splits.values() for f in object_folds(o)]
    lin = method_values(splits, "linear", reducer="max-min", rate_hz=1000.0)
    assert sorted(lin) == sorted((f.object, f.velocity) for f in folds)
    assert all(lin[(f.object, f.velocity)] == pytest.approx(f.linear, rel=1e-9, abs=1e-9) for f in folds)
    row = summarise(folds, method_values(splits, "ensemble-warp", reducer="max-min", rate_hz=1000.0))["all"]
    assert 0.5 < row["method_share"] < row["ceiling"] + 0.02
    assert row["method"] < 0.5 * row["linear"]


@pytest.mark.parametrize("drops, recorded", [(15, 10), (20, 1)])
def test_too_few_drops_is_a_clear_error(drops, recorded):
    v, d = _drops(0.0, drops=drops, sigma=0.05)
    with pytest.raises(DatasetError, match=r"object 'flat': .* drops per velocity; .*--drops 60"):
        object_folds(split("flat", v, d, recorded))


SPEC = {
    "name": "dense-mini", "seed": 5, "drops": 2,
    "rig": {"helmet": {"mass": 2.8}},
    "objects": [{"id": "tile", "mass_kg": 0.12, "dimensions_mm": [100, 100, 8], "material": "ceramic",
                 "velocities_mps": [2.0, 2.6, 3.1, 3.7]}],
}


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "hapticfx", *args], capture_output=True, text=True)


def test_the_command_on_a_dense_simulated_set_prints_the_table_and_writes_json(tmp_path):
    (tmp_path / "spec.yaml").write_text(yaml.safe_dump(SPEC))
    r = _cli("data", "synth", str(tmp_path / "dense"), "--spec", str(tmp_path / "spec.yaml"), "--drops", "13",
             "--jobs", "1")
    assert r.returncode == 0, r.stderr
    r = _cli("bench", "ceiling", str(tmp_path / "dense"), "--recorded", "3", "-o", str(tmp_path / "c.json"))
    assert r.returncode == 0, r.stderr
    assert "gap share ceiling" in r.stdout and "| tile " in r.stdout and "| all " in r.stdout
    out = json.loads((tmp_path / "c.json").read_text())
    assert out["recorded"] == 3 and len(out["folds"]) == 2
    assert out["method"] == "ensemble-warp" and "method_share" in out["summary"]["all"]
    assert all(np.isfinite(x) for f in out["folds"]
               for x in [f["linear"], f["method"], *f["bias"].values(), *f["recorded"].values()])
    # the same set has too few drops to measure with 10 recorded: one line, exit 2, no file
    r = _cli("bench", "ceiling", str(tmp_path / "dense"), "-o", str(tmp_path / "d.json"))
    assert r.returncode == 2 and "13 drops per velocity" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "d.json").exists()
    # a row of `bench interpolators --config`: its options reach the interpolator (texture 0: nearer the mean)
    (tmp_path / "rows.yaml").write_text(yaml.safe_dump({"plain": {"interpolator": "ensemble-warp",
                                                                  "options": {"texture": 0.0}},
                                                        "bad": {"interpolator": "ensemble-warp",
                                                                "options": {"texture": 5.0}}}))
    r = _cli("bench", "ceiling", str(tmp_path / "dense"), "--recorded", "3", "--method", "plain", "--config",
             str(tmp_path / "rows.yaml"), "-o", str(tmp_path / "p.json"))
    assert r.returncode == 0, r.stderr
    plain = json.loads((tmp_path / "p.json").read_text())
    assert plain["method"] == "plain" and "gap share plain" in r.stdout
    assert [f["linear"] for f in plain["folds"]] == [f["linear"] for f in out["folds"]]
    r = _cli("bench", "ceiling", str(tmp_path / "dense"), "--recorded", "3", "--method", "nope", "--config",
             str(tmp_path / "rows.yaml"))
    assert r.returncode == 2 and "unknown method 'nope'" in r.stderr and "Traceback" not in r.stderr
    r = _cli("bench", "ceiling", str(tmp_path / "dense"), "--recorded", "3", "--method", "bad", "--config",
             str(tmp_path / "rows.yaml"))
    assert r.returncode == 2 and "texture must be <= 1.0" in r.stderr and "Traceback" not in r.stderr
