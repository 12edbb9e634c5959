"""bench texture: a right centre (the mean of the other drops) with each texture share, against linear."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest
import yaml

from hapticfx.evaluation.measures import drop_pairs, floors
from hapticfx.evaluation.texture_ceiling import Fold, fold, recorded, summarise
from hapticfx.interpolators.texture import TEXTURES
from hapticfx.processing.likeness import log_spectral_distance
from hapticfx.processing.perceptual import scores

RATE = 1000.0
T = np.arange(500) / RATE


def _drop(phase: float, rng) -> np.ndarray:
    """A 40 Hz half-sine pulse and a 230 Hz ring at ``phase``, plus a little noise."""
    pulse = np.where(T < 0.0125, np.sin(np.pi * T / 0.0125), 0.0)
    ring = 0.4 * np.exp(-T / 0.05) * np.sin(2 * np.pi * 230 * T + phase)
    return pulse + ring + 0.002 * rng.standard_normal(T.size)


def _out_of_phase(n=6, seed=0):
    rng = np.random.default_rng(seed)
    drops = np.stack([_drop(p, rng) for p in rng.uniform(0, 2 * np.pi, n)])
    blend = 0.5 * _drop(0.3, rng) + 0.5 * _drop(0.5, rng)
    return drops, blend


def test_without_texture_the_centre_scores_as_the_other_drops_mean_and_linear_as_the_bench_scores_it():
    drops, blend = _out_of_phase()
    f = fold("ring", 3.0, blend, drops, 2, rate_hz=RATE)
    assert f.textured[0.0]["lsd"] == pytest.approx(floors(drops, 2, rate_hz=RATE)["mean_of_others_lsd_db"], rel=1e-12)
    assert f.textured[0.0]["cost"] == 0.0
    assert f.linear["lsd"] == pytest.approx(float(np.mean(log_spectral_distance(blend, drops, rate_hz=RATE))))
    expected = scores(blend, drops, rate_hz=RATE)
    assert (f.linear["stsim"], f.linear["spqi"]) == pytest.approx((expected["stsim"], expected["spqi"]))
    assert f.floors["rmse_rep"] == pytest.approx(np.sqrt(np.mean((np.delete(drops, 2, 0).mean(0) - drops[2]) ** 2)))


def test_a_recorded_drop_scores_as_the_bench_scores_the_drops_against_each_other():
    drops, blend = _out_of_phase()
    f = fold("ring", 3.0, blend, drops, 1, rate_hz=RATE)
    pairs = drop_pairs(drops, rate_hz=RATE)
    assert f.recorded == pytest.approx({"lsd": floors(drops, 1, rate_hz=RATE)["drop_pairs_lsd_db"],
                                        "stsim": pairs["drop_to_drop_stsim"], "spqi": pairs["drop_to_drop_spqi"]})
    # rings out of phase: one recorded drop is far from the others in time, so its ST-SIM is below linear's blend
    # of two of them; the ratios are its means over the folds to linear's
    real = recorded([f, f])
    assert real["stsim"] == pytest.approx(f.recorded["stsim"] / f.linear["stsim"]) and real["stsim"] < 1.0
    assert real["perceptual_met"] is False
    real = recorded([_fold(1.0, 0.5, 0.0, lsd=0.98, stsim=1.0, spqi=1.01)])
    assert real == pytest.approx({"lsd": 0.98, "stsim": 1.0, "spqi": 1.01, "lsd_met": True, "perceptual_met": True})


def test_texture_restores_what_the_mean_of_out_of_phase_rings_loses_and_costs_rmse():
    drops, blend = _out_of_phase()
    f = fold("ring", 3.0, blend, drops, 0, rate_hz=RATE)
    lsd = [f.textured[b]["lsd"] for b in TEXTURES]
    cost = [f.textured[b]["cost"] for b in TEXTURES]
    assert lsd[0] > f.linear["lsd"]  # the mean of rings out of phase is dull: worse than a blend of two drops
    assert lsd[-1] < lsd[0]
    assert np.all(np.diff(cost) > 0)
    rows = summarise([f])
    assert rows[0]["share_mean"] == pytest.approx(1.0) and rows[0]["share_rep"] == pytest.approx(1.0)
    assert np.all(np.diff([r["share_mean"] for r in rows]) < 0)
    assert all(np.isfinite(v) for r in rows for v in r.values())


def test_a_fill_on_the_centre_restores_lsd_at_an_rmse_cost_each_share_and_fill_a_row():
    drops, blend = _out_of_phase()
    f = fold("ring", 3.0, blend, drops, 0, rate_hz=RATE, fills=(0.5, 1.0))
    assert set(f.filled) == {(b, g) for b in TEXTURES for g in (0.5, 1.0)}
    assert f.filled[(0.0, 1.0)]["lsd"] < f.filled[(0.0, 0.5)]["lsd"] < f.textured[0.0]["lsd"]
    assert 0.0 < f.filled[(0.0, 0.5)]["cost"] < f.filled[(0.0, 1.0)]["cost"]
    rows = summarise([f], fills=(0.5, 1.0))
    assert [(r["texture"], r["fill"]) for r in rows] == ([(b, 0.0) for b in TEXTURES]
                                                          + [(b, g) for g in (0.5, 1.0) for b in TEXTURES])
    assert rows[:len(TEXTURES)] == [{**r, "fill": 0.0} for r in summarise([f])]
    assert all(np.isfinite(v) for r in rows for v in r.values())


def _fold(lin_mean, floor_mean, cost, lsd=1.0, stsim=1.0, spqi=1.0):
    linear = {"lsd": 1.0, "stsim": 1.0, "spqi": 1.0, "rmse_mean": lin_mean, "rmse_rep": lin_mean}
    return Fold("o", 1.0, linear, {"rmse_mean": floor_mean, "rmse_rep": floor_mean},
                {0.0: {"lsd": lsd, "stsim": stsim, "spqi": spqi, "cost": cost}},
                {"lsd": lsd, "stsim": stsim, "spqi": spqi})


def test_shares_and_criteria_follow_the_bench_bar():
    # the floor 0.5 below linear's 1.0; the texture's cost 0.6 in quadrature: error 0.781, share 44 %
    (row,) = summarise([_fold(1.0, 0.5, 0.6, lsd=0.99, stsim=1.01, spqi=1.02)], betas=(0.0,))
    assert row["share_mean"] == pytest.approx((1.0 - np.hypot(0.5, 0.6)) / 0.5)
    assert row["criteria"] == 2  # both shares fail, LSD and the perceptual pair pass
    (row,) = summarise([_fold(1.0, 0.5, 0.0, lsd=1.01, stsim=1.01, spqi=0.99)], betas=(0.0,))
    assert row["share_mean"] == pytest.approx(1.0) and row["criteria"] == 2  # LSD and SPQI fail
    # linear already at the floor: no gap to share, as the bench reports it
    (row,) = summarise([_fold(0.5, 0.5, 0.0)], betas=(0.0,))
    assert np.isnan(row["share_mean"]) and row["criteria"] == 2


SPEC = {
    "name": "texture-mini", "seed": 7, "drops": 3,
    "rig": {"helmet": {"mass": 2.8}},
    "objects": [{"id": "tile", "mass_kg": 0.12, "dimensions_mm": [100, 100, 8], "material": "ceramic",
                 "velocities_mps": [2.0, 2.6, 3.1, 3.7]}],
}


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "hapticfx", *args], capture_output=True, text=True)


def test_the_command_prints_a_table_per_dataset_and_refuses_what_it_cannot_score(tmp_path):
    for name, drops in (("three", 3), ("one", 1)):
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump({**SPEC, "drops": drops}))
        r = _cli("data", "synth", str(tmp_path / name), "--spec", str(tmp_path / f"{name}.yaml"), "--jobs", "1")
        assert r.returncode == 0, r.stderr
    r = _cli("bench", "texture", str(tmp_path / "three"), "-o", str(tmp_path / "t.json"))
    assert r.returncode == 0, r.stderr
    assert "gap share (drop mean)" in r.stdout and len(re.findall(r"\| [0-4]/4 +\|", r.stdout)) == len(TEXTURES)
    out = json.loads((tmp_path / "t.json").read_text())
    (entry,) = out["datasets"].values()
    assert len(entry["folds"]) == 2 and [r["texture"] for r in entry["rows"]] == list(TEXTURES)
    assert all(np.isfinite(v) for r in entry["rows"] for v in r.values())
    r = _cli("bench", "texture", str(tmp_path / "three"), "--fill", "0.5")
    assert r.returncode == 0, r.stderr
    assert len(re.findall(r"\| [0-4]/4 +\|", r.stdout)) == 2 * len(TEXTURES) and "0.4 + fill 0.5" in r.stdout
    r = _cli("bench", "texture", str(tmp_path / "three"), "--fill", "2")
    assert r.returncode == 2 and "--fill" in r.stderr and "Traceback" not in r.stderr
    r = _cli("bench", "texture", str(tmp_path / "three"), str(tmp_path / "one"), "-o", str(tmp_path / "u.json"))
    assert r.returncode == 2 and "1 drop per velocity" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "u.json").exists()
    r = _cli("bench", "texture", str(tmp_path / "three"), "--reducer", "nope")
    assert r.returncode == 2 and "no 'nope' bank" in r.stderr and "Traceback" not in r.stderr
