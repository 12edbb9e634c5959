"""`hapticfx train`'s output folder and --ship, and the pre-training rigs drawn from written-down ranges."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from neural_testkit import tiny_config


def test_train_writes_to_a_user_folder_unless_told_to_ship(tmp_path, drop_dataset, monkeypatch):
    from typer.testing import CliRunner

    from hapticfx.cli import build_app
    from hapticfx_neural import checkpoint

    cfg = yaml.safe_load(tiny_config(tmp_path, drop_dataset, epochs=1).read_text())
    del cfg["out"]
    path = tmp_path / "no-out.yaml"
    path.write_text(yaml.safe_dump(cfg))
    monkeypatch.chdir(tmp_path)
    shipped = tmp_path / "shipped"
    monkeypatch.setattr(checkpoint, "WEIGHTS_DIR", shipped)
    r = CliRunner().invoke(build_app(), ["train", str(path), "--quiet"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "checkpoints" / "convbilstm-toy-drops-max-min" / "model.safetensors").is_file()
    assert not shipped.exists()
    out = shipped / "toy-drops" / "max-min" / "convbilstm"
    out.mkdir(parents=True)
    (out / "model.json").write_text("the weights shipped before")
    # a --ship run stopped after its checkpoints are written, before it ends, leaves the shipped weights as
    # they were (the stop is simulated: training runs for real, then the call raises)
    from hapticfx_neural import run

    real = run.train_from_config

    def stopped(*args, **kwargs):
        real(*args, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(run, "train_from_config", stopped)
    r = CliRunner().invoke(build_app(), ["train", str(path), "--quiet", "--ship"])
    assert r.exit_code != 0 and (out / "model.json").read_text() == "the weights shipped before"
    monkeypatch.setattr(run, "train_from_config", real)
    r = CliRunner().invoke(build_app(), ["train", str(path), "--quiet", "--ship"])
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in out.iterdir()) == ["model.json", "model.safetensors", "model.table.npz"]
    assert sorted(p.name for p in out.parent.iterdir()) == ["convbilstm"]
    assert not (tmp_path / "checkpoints" / "ship-convbilstm-toy-drops-max-min").exists()


def test_pretraining_draws_are_reproducible_valid_specs_on_dense_grids_with_their_own_seeds(tmp_path):
    from hapticfx.droprig.draws import HELDOUT_DRAW_SEEDS, HELDOUT_SIM_SEEDS, RANGES
    from hapticfx.droprig.spec import load_spec
    from hapticfx.droprig.synth import BUILTIN_SEED
    from hapticfx.errors import DatasetError
    from hapticfx_neural.pretrain.draws import GRID, PRETRAIN_SEED, draw_spec, write_specs

    paths = write_specs(tmp_path, 3)
    assert yaml.safe_load(paths[1].read_text()) == draw_spec(1) and draw_spec(1) != draw_spec(2)
    for k, p in enumerate(paths):
        spec = load_spec(p)
        assert spec.seed == PRETRAIN_SEED + k != BUILTIN_SEED and spec.drops == GRID["drops"]
        assert spec.seed not in HELDOUT_DRAW_SEEDS and spec.seed not in HELDOUT_SIM_SEEDS
        for o in spec.objects:
            assert RANGES["mass_kg"][0] <= o.mass_kg <= RANGES["mass_kg"][1]
            vs = spec.velocities[o.id]
            assert len(vs) == GRID["velocities_per_object"] and np.allclose(np.diff(vs), GRID["velocity_step_mps"])
            assert RANGES["v_min_mps"][0] <= vs[0] and vs[-1] <= RANGES["v_max_mps"][1]
    with pytest.raises(DatasetError, match="reserved for the held-out evaluation sets"):
        draw_spec(0, seed=HELDOUT_DRAW_SEEDS.start)


def test_bench_threads_default_config_is_the_shipped_one():
    from hapticfx_neural import checkpoint
    from hapticfx_neural.bench.threads import SHIPPED_CONFIG
    from hapticfx_neural.config import load_config

    cfg = load_config(SHIPPED_CONFIG)
    meta = checkpoint.read_meta(checkpoint.default_weights("helmet-drops", "max-min", "convbilstm"))
    assert cfg.interpolator == meta["interpolator"] == "convbilstm" and cfg.model == meta["model"]


def test_the_shipped_fine_tuning_configuration_finds_its_pre_trained_weights():
    """The pre-trained checkpoint ships beside the configuration that fine-tunes it; their sizes agree."""
    from hapticfx_neural import checkpoint
    from hapticfx_neural.checkpoint import read_meta, resolve
    from hapticfx_neural.config import load_config

    cfg = load_config(checkpoint.WEIGHTS_DIR.parent / "configs" / "helmet-drops-convbilstm-pretrained.yaml")
    meta = read_meta(resolve(cfg.init_path()))
    assert meta["model"] == cfg.model and meta["interpolator"] == cfg.interpolator
    assert meta["training"]["input_drops"] == 10 and len(meta["dataset"]["datasets"]) == 16
    assert meta["training"]["best_epoch"] > 5
