"""Training from every drop: triples over drop pools, centres as inputs, fine-tuning, pre-training draws."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from neural_testkit import TINY, tiny_config

from hapticfx.data.dataset import open_dataset
from hapticfx.data.training import recorded_drops, training_data
from hapticfx.errors import CheckpointError, EffectError
from hapticfx.registry import get_registry
from hapticfx_neural.config import load_config
from hapticfx_neural.run import train_from_config, triples_of
from hapticfx_neural.samples import drop_triples


def test_triples_take_every_gap_and_the_target_is_the_drop_mean():
    rng = np.random.default_rng(0)
    v = np.array([1.0, 1.1, 1.2, 1.3, 1.4])
    pools = [rng.standard_normal((4, 20)) for _ in v]
    t = drop_triples([("a", v, pools, [1.2])], gaps=[1, 2])
    assert sorted(zip(t.v_lo.tolist(), t.v_hi.tolist())) == [(1.0, 1.3), (1.0, 1.4), (1.1, 1.3), (1.1, 1.4)]
    full = t.centres()
    assert np.allclose(full.target, pools[2].mean(axis=0)) and np.allclose(full.lower_c[0], pools[t.lo[0]].mean(0))
    a, b = t.centres(np.random.default_rng(5)), t.centres(np.random.default_rng(5))
    assert np.array_equal(a.lower_c, b.lower_c)  # seeded: a resumed run draws the same inputs
    drawn = [t.centres(np.random.default_rng(s)).lower_c[0] for s in range(40)]
    assert len({x.tobytes() for x in drawn}) > 1 and np.allclose(a.target, full.target)
    subsets = [pools[t.lo[0]][list(c)].mean(0) for k in (2, 3, 4)
               for c in __import__("itertools").combinations(range(4), k)]
    assert all(any(np.allclose(d, s) for s in subsets) for d in drawn)  # half of the drops or more


def test_input_drops_limits_the_inputs_centres_and_leaves_the_target_the_centre_of_every_drop():
    """Pre-training on a rig recorded 60 times: the inputs are what K recorded drops give, the target is clean."""
    import dataclasses
    import itertools

    rng = np.random.default_rng(1)
    v = np.array([1.0, 1.1, 1.2])
    pools = [rng.standard_normal((12, 20)) for _ in v]
    t = dataclasses.replace(drop_triples([("a", v, pools, [1.1])], gaps=[1]), input_drops=4)
    fixed = t.centres()
    assert np.allclose(fixed.lower_c[0], pools[0][:4].mean(0)) and np.allclose(fixed.upper_c[0], pools[2][:4].mean(0))
    assert np.allclose(fixed.target[0], pools[1].mean(0))
    drawn = [t.centres(np.random.default_rng(s)) for s in range(40)]
    subsets = [pools[0][list(c)].mean(0) for k in (2, 3, 4) for c in itertools.combinations(range(12), k)]
    assert all(any(np.allclose(d.lower_c[0], s) for s in subsets) for d in drawn)  # 2 to 4 of the 12 drops
    assert len({d.lower_c[0].tobytes() for d in drawn}) > 1
    assert all(np.allclose(d.target[0], pools[1].mean(0)) for d in drawn)
    assert t.subset([0]).input_drops == 4


def test_a_range_of_input_drops_draws_that_many_and_validates_on_one_fixed_draw_in_it():
    """Pre-training for users who record as few as 3 drops: inputs from 3 to 6 of 12, the target still clean."""
    import dataclasses
    import itertools

    rng = np.random.default_rng(2)
    v = np.array([1.0, 1.1, 1.2])
    pools = [rng.standard_normal((12, 20)) for _ in v]
    t = dataclasses.replace(drop_triples([("a", v, pools, [1.1])], gaps=[1]), input_drops=[3, 6])
    sizes = set()
    for s in range(60):
        d = t.centres(np.random.default_rng(s))
        size = next(k for k in range(1, 13) for c in itertools.combinations(range(12), k)
                    if k in (3, 4, 5, 6) and np.allclose(d.lower_c[0], pools[0][list(c)].mean(0)))
        sizes.add(size)
        assert np.allclose(d.target[0], pools[1].mean(0))
    assert sizes == {3, 4, 5, 6}  # every count of the range, and no other
    fixed, again = t.centres(), t.centres()
    assert np.array_equal(fixed.lower_c, again.lower_c)  # validation sees the same inputs every epoch
    chosen = t.fixed_inputs(0)
    assert 3 <= len(chosen) <= 6 and np.allclose(fixed.lower_c[0], chosen.mean(0))
    assert not np.allclose(fixed.lower_c[0], pools[0].mean(0))
    assert t.input_counts(0) == (3, 6) and dataclasses.replace(t, input_drops=[3, 40]).input_counts(0) == (3, 12)


def test_training_validates_on_what_input_drops_recorded_drops_give():
    from hapticfx_neural.config import MODEL_DEFAULTS, TRAINING_DEFAULTS
    from hapticfx_neural.training import train_network

    rng = np.random.default_rng(4)
    v = np.round(np.linspace(1.0, 2.0, 11), 6)
    pools = [np.sin(np.arange(100) * x / 7)[None] + 0.3 * rng.standard_normal((8, 100)) for x in v]
    data = drop_triples([("a", v, pools, list(v[1:-1]))], gaps=[1])
    model = {**MODEL_DEFAULTS["convbilstm"], **TINY}

    def start(k):
        training = {**TRAINING_DEFAULTS, "epochs": 1, "input_drops": k}
        _, meta = train_network("convbilstm", model, training, data, dataset_meta={"name": "a"}, progress=False)
        return meta["training"]["start_val_rmse_normalised"], meta["training"]["input_drops"]

    every, one, all_eight = start(None), start(1), start(8)
    assert every[0] == all_eight[0] and one[1] == 1
    assert abs(one[0] - every[0]) > 0.1 * every[0]  # the first drop alone as each input: another start


def test_input_drops_must_be_a_positive_integer_a_range_of_them_or_null(tmp_path):
    for bad in (0, -3, 2.5, True, "ten", [3], [5, 3], [0, 4], [3, 4, 5], [3, 4.5]):
        path = tmp_path / "c.yaml"
        path.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "builtin:helmet-drops",
                                        "training": {"input_drops": bad}}))
        with pytest.raises(EffectError) as err:
            load_config(path)
        assert "training.input_drops" in str(err.value) and str(path) in str(err.value)
    path.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "builtin:helmet-drops",
                                    "training": {"input_drops": None}}))
    assert load_config(path).training["input_drops"] is None
    path.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "builtin:helmet-drops",
                                    "training": {"input_drops": [3, 10]}}))
    assert load_config(path).training["input_drops"] == [3, 10]


def test_trimmed_centres_are_the_cores_trimmed_means_for_inputs_draws_and_target():
    from hapticfx.interpolators.ensemble import centres

    rng = np.random.default_rng(2)
    v = np.array([1.0, 1.1, 1.2])
    pools = [rng.standard_normal((10, 20)) for _ in v]
    pools[2][0] += 50.0  # one wild drop: the median-like centre ignores it, the mean does not
    t = drop_triples([("a", v, pools, [1.1])], gaps=[1], trim=0.4)
    full = t.centres()
    assert np.allclose(full.target, centres(pools[1][None], 0.4)[0])
    assert np.allclose(full.upper_c[0], np.median(pools[2], axis=0)) and np.abs(full.upper_c[0]).max() < 10
    drawn = t.subset([0]).centres(np.random.default_rng(3))
    assert np.allclose(drawn.target, full.target) and not np.allclose(drawn.lower_c, full.lower_c)


def test_an_untrained_trimmed_network_is_the_ensemble_with_that_trim(drop_dataset):
    """``trim`` in a training configuration: the untrained network serves exactly what `ensemble` does."""
    from hapticfx.interpolators.ensemble import EnsembleInterpolator
    from hapticfx_neural.config import MODEL_DEFAULTS
    from hapticfx_neural.samples import Centres, stack_triples
    from hapticfx_neural.training import make_network, predict

    ds = open_dataset(drop_dataset)
    bank = ds.bank("wood-beam", "max-min")
    centres = Centres(0.3)
    centres.add(bank, recorded_drops(ds, "wood-beam", "max-min"))
    net = make_network("convbilstm", {**MODEL_DEFAULTS["convbilstm"], **TINY}, bank.n_samples)
    meta = {"steps": TINY["steps"], "normalisation": {"velocity_mean": 3.0, "velocity_std": 1.0}}
    ens = EnsembleInterpolator(trim=0.3)
    ens.fit(training_data(ds, "max-min", ["wood-beam"]))
    ens.prepare(bank)
    lo, hi = bank[1], bank[2]
    for w in (0.0, 0.2, 0.5, 0.9, 1.0):
        v = lo.velocity + w * (hi.velocity - lo.velocity)
        out = predict(net, meta, stack_triples([(lo, hi, v, None)], ["wood-beam"], centres))[0]
        assert np.allclose(out, ens.interpolate(lo, hi, v), rtol=0, atol=1e-9)


def test_an_untrained_network_serves_the_blend_drawn_toward_the_centres(drop_dataset):
    """Zero correction: halfway, the mean of the neighbours' centres; at a neighbour, its representative."""
    from hapticfx_neural.config import MODEL_DEFAULTS
    from hapticfx_neural.samples import Centres, stack_triples
    from hapticfx_neural.training import make_network, predict

    ds = open_dataset(drop_dataset)
    bank = ds.bank("wood-beam", "max-min")
    velocities, drops = recorded_drops(ds, "wood-beam", "max-min")
    centres = Centres()
    centres.add(bank, (velocities, drops))
    net = make_network("convbilstm", {**MODEL_DEFAULTS["convbilstm"], **TINY}, bank.n_samples)
    meta = {"steps": TINY["steps"], "normalisation": {"velocity_mean": 3.0, "velocity_std": 1.0}}
    lo, hi = bank[1], bank[2]
    for v, want in ((0.5 * (lo.velocity + hi.velocity), 0.5 * (drops[1].mean(0) + drops[2].mean(0))),
                    (lo.velocity, lo.samples), (hi.velocity, hi.samples)):
        out = predict(net, meta, stack_triples([(lo, hi, v, None)], ["wood-beam"], centres))[0]
        assert np.allclose(out, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("trim, inputs", [(0.0, "centres"), (0.4, "centres"), (0.1, "pooled")])
def test_training_from_drops_serves_a_table_equal_to_direct_inference(tmp_path, drop_dataset, trim, inputs):
    cfg = load_config(tiny_config(tmp_path, drop_dataset, epochs=2))
    cfg.trim, cfg.inputs = trim, inputs
    meta, path = train_from_config(cfg, progress=False)
    assert meta["dataset"]["trim"] == trim and meta["dataset"]["inputs"] == inputs
    t = meta["training"]
    assert t["epochs_run"] == 2 and len(t["history"]) == 2 and t["start_val_rmse_normalised"] is None  # 4 targets
    assert meta["dataset"]["targets"] == {"wood-beam": [2.8, 3.1, 3.4, 3.7]}
    ds = open_dataset(drop_dataset)
    bank = ds.bank("wood-beam", "max-min")
    tabled = get_registry().create("interpolator", "convbilstm", weights=str(path))
    direct = get_registry().create("interpolator", "convbilstm", weights=str(path), cache=False)
    tabled.prepare(bank, dataset=ds)
    direct.prepare(bank, dataset=ds)
    assert tabled.net is None
    if inputs == "pooled":  # served from the centres ensemble-warp pools, fitted again from the dataset's drops
        from hapticfx_neural.pooled import pooling

        want = pooling(training_data(ds, "max-min", ["wood-beam"])).centres["wood-beam"]
        assert all(np.array_equal(direct.centres(bank[k]), want[k]) for k in range(len(bank)))
    for v in np.linspace(2.41, 3.99, 37):
        lo, hi = bank.neighbours(float(v))
        a, b = tabled.interpolate(lo, hi, float(v)), direct.interpolate(lo, hi, float(v))
        assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b))


def test_fine_tuning_starts_from_the_given_weights_and_refuses_other_sizes(tmp_path, drop_dataset):
    _, pre = train_from_config(load_config(tiny_config(tmp_path, drop_dataset, epochs=1)), progress=False)
    cfg = load_config(tiny_config(tmp_path, drop_dataset, epochs=1))
    cfg.init, cfg.out = str(pre.parent), str(tmp_path / "fine")
    meta, _ = train_from_config(cfg, progress=False)
    from hapticfx_neural import checkpoint

    assert meta["init"]["weights_sha256"] == checkpoint.read_meta(pre)["weights_sha256"]
    assert meta["normalisation"] == checkpoint.read_meta(pre)["normalisation"]
    cfg.model["decoder_sizes"] = [5]
    cfg.out = str(tmp_path / "other")
    with pytest.raises(CheckpointError, match="cannot fine-tune: its model sizes"):
        train_from_config(cfg, progress=False)


def test_a_bench_row_fine_tunes_from_init_relative_to_its_configuration_file(tmp_path, drop_dataset, monkeypatch):
    """As `hapticfx train` reads it: a configuration names its pre-trained weights beside it, wherever the bench
    runs."""
    import yaml

    from hapticfx.data.training import training_data
    from hapticfx_neural import checkpoint

    _, pre = train_from_config(load_config(tiny_config(tmp_path, drop_dataset, epochs=1)), progress=False)
    path = tiny_config(tmp_path, drop_dataset, epochs=1)
    cfg = yaml.safe_load(path.read_text())
    cfg["init"] = str(pre.relative_to(tmp_path))
    path.write_text(yaml.safe_dump(cfg))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    ds = open_dataset(drop_dataset)
    interp = get_registry().create("interpolator", "convbilstm", config=str(path))
    interp.fit(training_data(ds, "max-min", ds.objects))
    assert interp.meta["init"]["weights_sha256"] == checkpoint.read_meta(pre)["weights_sha256"]


def test_the_bench_runner_trains_on_drops_with_the_fold_held_out(drop_dataset):
    """TrainingData without the held-out velocity: it is neither a target nor an input pool."""
    ds = open_dataset(drop_dataset)
    data = training_data(ds, "max-min", holdout={"wood-beam": [3.1]})
    t, targets = triples_of(data, gaps=[1])
    assert targets == {"wood-beam": [2.8, 3.4, 3.7]} and 3.1 not in t.v_lo.tolist() + t.v_hi.tolist()
    interp = get_registry().create("interpolator", "convbilstm")
    summary = interp.fit(data, model=TINY, training={"epochs": 1})
    assert summary["epochs_run"] == 1


@pytest.mark.parametrize("bad, key", [({"gaps": [0]}, "gaps"), ({"gaps": "1"}, "gaps"), ({"dataset": []}, "dataset"),
                                      ({"init": 3}, "init"), ({"training": {"augment": "yes"}}, "training.augment"),
                                      ({"trim": 0.5}, "trim"), ({"trim": True}, "trim")])
def test_bad_drop_training_keys_name_the_key(tmp_path, bad, key):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "x", **bad}))
    with pytest.raises(EffectError) as err:
        load_config(path)
    assert str(path) in str(err.value) and key in str(err.value)


@pytest.mark.parametrize("holdout, message", [
    ([3.1, 3.11], "holdout_velocities: 3.11 m/s is no recorded velocity of any object of toy-drops"),
    ([2.4, 2.8, 3.1, 3.4, 3.7, 4.0], "holdout_velocities: holds out every recorded velocity of object 'wood-beam'")])
def test_a_holdout_velocity_that_holds_nothing_out_is_an_error(tmp_path, drop_dataset, holdout, message):
    """3.11 for 3.1 held nothing out and trained on 3.1, which an evaluation then took for unseen; holding out
    every velocity said `bank 'wood-beam' velocities is empty`, naming neither the file nor the key."""
    from hapticfx_neural.run import config_triples

    cfg = load_config(tiny_config(tmp_path, drop_dataset, epochs=1))
    cfg.holdout_velocities = holdout
    with pytest.raises(EffectError) as err:
        config_triples(cfg)
    assert str(err.value).startswith(f"{cfg.source}: {message}")


@pytest.mark.parametrize("setting, message", [
    ({"objects": ["nope"]}, "objects: dataset 'toy-drops' has no object 'nope'"),
    ({"train_velocities": [9.9]}, "train_velocities: none of 9.9 m/s is a recorded velocity of toy-drops"),
    ({"train_velocities": [3.1, 3.11]}, "train_velocities: 3.11 m/s is no recorded velocity"),
])
def test_objects_and_train_velocities_the_dataset_lacks_name_the_config_and_key(tmp_path, drop_dataset, setting,
                                                                                message):
    """Each said what was missing but named neither the file nor the key (or, 3.11, said nothing)."""
    from hapticfx_neural.run import config_triples

    cfg = load_config(tiny_config(tmp_path, drop_dataset, epochs=1))
    for key, value in setting.items():
        setattr(cfg, key, value)
    with pytest.raises(EffectError) as err:
        config_triples(cfg)
    assert str(err.value).startswith(f"{cfg.source}: {message}")


def test_noise_budget_tells_noise_from_a_learnable_change():
    """Pools around one profile: the blend's error is all sampling noise; a curved truth adds what is not."""
    from hapticfx_neural.bench.learnable import noise_budget

    rng = np.random.default_rng(1)
    v = np.linspace(1.0, 2.0, 11)
    base = np.sin(np.linspace(0, 6, 50))
    flat = [base + rng.standard_normal((10, 50)) * 0.1 for _ in v]
    obs, noise = noise_budget(drop_triples([("a", v, flat, list(v[1:-1]))], gaps=[1]))
    assert 0.7 < noise / obs < 1.3
    curved = [base * (1 + 40 * (x - 1.5) ** 2) + rng.standard_normal((10, 50)) * 0.1 for x in v]
    obs, noise = noise_budget(drop_triples([("a", v, curved, list(v[1:-1]))], gaps=[1]))
    assert noise / obs < 0.5


def test_noise_budget_counts_the_inputs_noise_from_input_drops_drops():
    """60 drops per velocity, inputs from 10: the neighbours' means carry 10 drops' noise, the target 60's."""
    import dataclasses

    from hapticfx_neural.bench.learnable import noise_budget

    rng = np.random.default_rng(2)
    v = np.linspace(1.0, 2.0, 11)
    pools = [np.sin(np.linspace(0, 6, 50)) + rng.standard_normal((60, 50)) * 0.1 for _ in v]
    data = drop_triples([("a", v, pools, list(v[1:-1]))], gaps=[1])
    every, ten = noise_budget(data), noise_budget(dataclasses.replace(data, input_drops=10))
    # at w = 1/2: (1/4 + 1/4) s^2 / D + s^2 / 60, so 0.5/10 + 1/60 against 0.5/60 + 1/60 (s^2 = 0.01)
    assert ten[1] == pytest.approx(0.01 * (0.05 + 1 / 60), rel=0.1)
    assert every[1] == pytest.approx(0.01 * (0.5 / 60 + 1 / 60), rel=0.1)
    assert 0.7 < ten[1] / ten[0] < 1.3


def test_training_tells_while_it_builds_the_velocity_table(tmp_path, drop_dataset, capsys):
    """The table after training took 72 of a 93 s run on a terminal without a word: it is told object by object."""
    train_from_config(load_config(tiny_config(tmp_path, drop_dataset, epochs=1)), progress=True)
    lines = capsys.readouterr().err.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("velocity table: tabulating the network"))
    told = [line for line in lines[start + 1:] if " intervals, " in line and line.endswith(" nodes")]
    assert len(told) == len(open_dataset(drop_dataset).objects)
