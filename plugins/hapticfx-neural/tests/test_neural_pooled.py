"""``inputs: pooled``: the network reads its neighbours' centres as ensemble-warp pools them across velocity."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from neural_testkit import TINY

from hapticfx.data.bank import ProfileBank
from hapticfx.errors import EffectError
from hapticfx.interfaces import TrainingData
from hapticfx.registry import get_registry
from hapticfx_neural.config import load_config
from hapticfx_neural.pooled import pooled_triples, pooling
from hapticfx_neural.run import triples_of

N = 100


def _noisy(drops: int = 3, noise: float = 0.1) -> TrainingData:
    """One object recorded ``drops`` times at 9 velocities: a pulse growing linearly with velocity, white noise."""
    rng = np.random.default_rng(5)
    v = np.linspace(2.0, 5.0, 9)
    t = np.arange(N)
    truth = np.stack([x * np.exp(-0.5 * ((t - 20) / 3.0) ** 2) for x in v])
    d = truth[:, None, :] + noise * rng.standard_normal((len(v), drops, N))
    bank = ProfileBank("brick", "max-min", 1000.0, v, d[:, 0].copy())
    return TrainingData({"brick": bank}, "max-min", "synthetic", {"brick": (v, d)})


def test_a_triples_inputs_are_its_neighbours_centres_pooled_without_its_target():
    data = _noisy()
    fit = pooling(data)
    assert fit.smooth["brick"] is not None or fit.shrink["brick"]  # 3 noisy drops: this object is pooled
    triples, _ = triples_of(data, gaps=[1, 2], trim=0.1)
    pooled = pooled_triples(data, triples, fit)
    v = data.banks["brick"].velocities
    left_out_mattered = False
    for n in range(len(triples)):
        i = int(np.flatnonzero(v == triples.v[n])[0])
        kept = np.delete(v, i)
        without = fit.centres_without("brick", i)
        lo, hi = (int(np.flatnonzero(kept == x)[0]) for x in (triples.v_lo[n], triples.v_hi[n]))
        assert np.array_equal(pooled.given[0][n], without[lo]) and np.array_equal(pooled.given[1][n], without[hi])
        left_out_mattered |= not np.allclose(without[lo], fit.centres["brick"][int(np.flatnonzero(v == v[i - 1])[0])])
    assert left_out_mattered
    # the inputs are fixed, drawn or not; the target stays the centre of the target's drops
    drawn, full = pooled.centres(np.random.default_rng(0)), triples.centres()
    assert np.array_equal(drawn.lower_c, pooled.given[0]) and np.array_equal(drawn.target, full.target)
    sub = pooled.subset([3, 1])
    assert np.array_equal(sub.centres().upper_c, pooled.given[1][[3, 1]])


def test_a_network_fitted_on_pooled_inputs_reads_the_centres_pooled_over_every_velocity(tmp_path):
    data = _noisy()
    config = tmp_path / "pooled.yaml"
    config.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "synthetic", "inputs": "pooled",
                                      "model": TINY, "training": {"epochs": 1}}))
    interp = get_registry().create("interpolator", "convbilstm", config=str(config))
    summary = interp.fit(data)
    assert summary["epochs_run"] == 1 and interp.meta["dataset"]["inputs"] == "pooled"
    bank = data.banks["brick"]
    want = pooling(data).centres["brick"]
    for k in range(len(bank)):
        assert np.array_equal(interp.centres(bank[k]), want[k])
    out = interp.interpolate(bank[3], bank[4], float(0.5 * (bank.velocities[3] + bank.velocities[4])))
    assert out.shape == (N,) and np.all(np.isfinite(out))


@pytest.mark.parametrize("bad", ["raw", 1, None])
def test_inputs_must_name_what_the_network_reads(tmp_path, bad):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "x", "inputs": bad}))
    with pytest.raises(EffectError) as err:
        load_config(path)
    assert str(path) in str(err.value) and "inputs" in str(err.value) and "pooled" in str(err.value)


def test_pooled_inputs_refuse_input_drops_which_draws_raw_centres(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({"interpolator": "convbilstm", "dataset": "x", "inputs": "pooled",
                                    "training": {"input_drops": 10}}))
    with pytest.raises(EffectError) as err:
        load_config(path)
    assert str(path) in str(err.value) and "training.input_drops" in str(err.value)
