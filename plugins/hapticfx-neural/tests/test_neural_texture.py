"""The texture of a trained network's profiles: fixed or chosen on its validation targets, served by its table."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
import yaml
from neural_testkit import tiny_config

from hapticfx.data.dataset import open_dataset
from hapticfx.errors import CheckpointError, EffectError
from hapticfx.interpolators.texture import KEEP_SHARE, TEXTURES, keep
from hapticfx.registry import get_registry
from hapticfx_neural.config import load_config
from hapticfx_neural.run import train_from_config


@pytest.fixture(scope="module")
def wide_drops(tmp_path_factory):
    """One toy object with raw drops at 9 velocities (7 targets: validation holds out whole target velocities
    from 5 on)."""
    from hapticfx.data.build import build_dataset
    from hapticfx.data.toy import toy_recordings
    from hapticfx.objects import PAPER_OBJECTS

    rec = toy_recordings(PAPER_OBJECTS["wood-beam"], [2.4, 2.6, 2.8, 3.0, 3.2, 3.4, 3.6, 3.8, 4.0], drops=4, seed=5)
    return build_dataset(tmp_path_factory.mktemp("wide") / "toy-wide", [rec], name="toy-wide", rate_hz=1000.0,
                         sensor={}, provenance={"generator": "hapticfx.data.toy (tests)"})


def _train(tmp_path, dataset, texture, name, **training):
    path = tiny_config(tmp_path, dataset, epochs=2, learning_rate=1e-2, **training)
    cfg = yaml.safe_load(path.read_text())
    cfg.update(texture=texture, out=str(tmp_path / name), trim=0.1)
    path.write_text(yaml.safe_dump(cfg))
    meta, weights = train_from_config(load_config(path), progress=False)
    return meta, weights


def _profiles(weights, dataset, cache):
    ds = open_dataset(dataset)
    bank = ds.bank(ds.objects[0], "max-min")
    interp = get_registry().create("interpolator", "convbilstm", weights=str(weights), cache=cache)
    interp.prepare(bank, dataset=ds)
    out = []
    for i in range(len(bank) - 1):
        lo, hi = bank[i], bank[i + 1]
        for w in (0.2, 0.5, 0.9):
            v = lo.velocity + w * (hi.velocity - lo.velocity)
            out.append((lo.samples, hi.samples, w, interp.interpolate(lo, hi, v)))
    return out, bank.rate_hz


@pytest.mark.parametrize("cache", [True, False])
def test_a_fixed_texture_keeps_that_share_of_the_neighbours_detail_in_the_table_and_in_direct_inference(
        tmp_path_factory, drop_dataset, cache):
    tmp = tmp_path_factory.mktemp("texture")
    plain_meta, plain = _train(tmp, drop_dataset, 0.0, "plain")
    kept_meta, kept = _train(tmp, drop_dataset, 0.5, "kept")
    assert "texture" not in plain_meta and kept_meta["texture"]["share"] == 0.5
    # the same training, the same weights; only the serving differs
    assert plain.read_bytes() == kept.read_bytes()
    a, rate = _profiles(plain, drop_dataset, cache)
    b, _ = _profiles(kept, drop_dataset, cache)
    moved = 0.0
    for (lo, hi, w, pa), (_, _, _, pb) in zip(a, b):
        blend = (1 - w) * lo + w * hi
        expected = blend + keep(pa - blend, 0.5, rate)  # keep is linear: the bump 4w(1-w) factors out
        assert np.max(np.abs(pb - expected)) <= 1e-6 * np.max(np.abs(pa))
        moved = max(moved, float(np.max(np.abs(pb - pa))))
    assert moved > 1e-3 * max(np.max(np.abs(p[3])) for p in a)  # the texture changed the profiles


def test_texture_choose_records_a_choice_its_validation_scores_support(tmp_path, wide_drops):
    meta, weights = _train(tmp_path, wide_drops, "choose", "chosen", val_fraction=0.4)  # 3 of its 7 targets
    t = meta["texture"]
    assert t["share"] in TEXTURES and t["chosen_on"].endswith("validation triples") and t["rate_hz"] == 1000.0
    scores = t["scores"]
    assert set(scores) == {"linear", *map(str, TEXTURES)}
    admissible = [b for b in TEXTURES if b == 0 or scores[str(b)]["share"] >= KEEP_SHARE]
    assert t["share"] in admissible
    assert scores[str(t["share"])]["expected_criteria"] == max(scores[str(b)]["expected_criteria"] for b in admissible)
    assert all(math.isfinite(scores[str(b)]["lsd"]) for b in TEXTURES)
    assert json.loads(weights.with_suffix(".json").read_text())["texture"]["share"] == t["share"]
    _profiles(weights, wide_drops, True)  # its table serves
    none, _ = _train(tmp_path, wide_drops, "choose", "unvalidated", val_fraction=0.0)
    assert "texture" not in none  # nothing to choose on: none kept


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), "auto", True, [0.2]])
def test_a_texture_is_a_share_in_0_1_or_choose(tmp_path, bad):
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "builtin:helmet-drops", "texture": bad}))
    with pytest.raises(EffectError, match=r"texture.*expected a number in \[0, 1\].*or choose"):
        load_config(path)


def test_a_table_built_for_another_texture_or_a_corrupt_texture_is_refused(tmp_path, drop_dataset):
    _, weights = _train(tmp_path, drop_dataset, 0.4, "ck")
    ck = tmp_path / "copy"
    shutil.copytree(weights.parent, ck)
    meta_file = ck / "model.json"
    meta = json.loads(meta_file.read_text())
    meta["texture"]["share"] = 0.6
    meta_file.write_text(json.dumps(meta))
    with pytest.raises(CheckpointError, match=r"stale: built for texture 0.4, now 0.6; rebuild it with `hapticfx table"):
        _profiles(ck, drop_dataset, True)
    meta["texture"] = {"share": "lots", "rate_hz": 1000.0}
    meta_file.write_text(json.dumps(meta))
    with pytest.raises(CheckpointError, match=r"model.json.*texture.*share in \[0, 1\]"):
        _profiles(ck, drop_dataset, True)
