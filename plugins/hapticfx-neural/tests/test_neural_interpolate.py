"""Inference, the velocity cache, continuity and range through the core data-driven model."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.data.dataset import open_dataset
from hapticfx.errors import SignalError
from hapticfx.interfaces import Profile
from hapticfx.registry import get_registry


@pytest.fixture()
def bank_and_interp(trained, syn_dataset):
    ds = open_dataset(syn_dataset)
    bank = ds.bank("steel-plate", "max-min")
    interp = get_registry().create("interpolator", "convbilstm", weights=str(trained))
    interp.prepare(bank, dataset=ds)
    return ds, bank, interp


def test_velocity_outside_the_neighbours_is_refused(bank_and_interp):
    _, bank, interp = bank_and_interp
    lo, hi = bank.neighbours(3.0)
    with pytest.raises(SignalError, match="must lie between the neighbours"):
        interp.interpolate(lo, hi, 3.5)
    with pytest.raises(SignalError, match="non-finite"):
        interp.interpolate(Profile(lo.velocity, lo.samples * np.nan), hi, 3.0)


def test_prediction_is_deterministic_and_batch_independent(bank_and_interp):
    _, bank, interp = bank_and_interp
    lo, hi = bank.neighbours(4.0)
    a = interp.interpolate(lo, hi, 4.0)
    b = interp.interpolate(lo, hi, 4.0)
    assert np.array_equal(a, b)


def test_cache_matches_direct_on_grid_nodes_and_recorded_at_the_ends(trained, syn_dataset):
    ds = open_dataset(syn_dataset)
    bank = ds.bank("steel-plate", "max-min")
    direct = get_registry().create("interpolator", "convbilstm", weights=str(trained))
    direct.prepare(bank, dataset=ds)
    cached = get_registry().create("interpolator", "convbilstm", weights=str(trained), cache=True, grid_step_mps=0.05)
    cached.prepare(bank, dataset=ds)
    lo, hi = bank[3], bank[4]  # 3.43 .. 3.70
    node = lo.velocity + 0.1
    assert np.allclose(cached.interpolate(lo, hi, node), direct.interpolate(lo, hi, node), atol=1e-5)
    assert np.allclose(cached.interpolate(lo, hi, lo.velocity), lo.samples)
    assert np.allclose(cached.interpolate(lo, hi, hi.velocity), hi.samples)
    between = lo.velocity + 0.125  # halfway between two nodes: the blend of both
    blend = 0.5 * (direct.interpolate(lo, hi, lo.velocity + 0.1) + direct.interpolate(lo, hi, lo.velocity + 0.15))
    assert np.allclose(cached.interpolate(lo, hi, between), blend, atol=1e-5)


@pytest.mark.parametrize("cache", [False, True])
def test_model_level_continuity_and_range(trained, syn_dataset, cache):
    from hapticfx.models.datadriven import DataDrivenModel
    from hapticfx.params import BuildContext

    params = DataDrivenModel.Params(dataset=str(syn_dataset), interpolator="convbilstm",
                                    interpolator_options={"weights": str(trained), "cache": cache})
    model = DataDrivenModel(params, BuildContext(object_id="plastic-frame"))
    bank = model.bank("plastic-frame")
    for v in np.concatenate([np.linspace(0.0, 20.0, 41), bank.velocities]):
        out = model.profile("plastic-frame", float(v))
        assert out.shape == (bank.n_samples,) and np.all(np.isfinite(out))
        assert np.max(np.abs(out)) < 100 * np.max(np.abs(bank.profiles))
    r = float(bank.velocities[5])
    assert np.array_equal(model.profile("plastic-frame", r), bank.profiles[5])
    near = model.profile("plastic-frame", r + 1e-6)
    jump = np.sqrt(np.mean((near - bank.profiles[5]) ** 2))
    if cache:  # the cache ends in the recorded profiles: continuous at recorded velocities
        assert jump < 1e-3 * np.sqrt(np.mean(bank.profiles[5] ** 2))
    else:  # direct inference: a jump, which the benchmark reports; here only finite
        assert np.isfinite(jump)



def test_cache_keeps_objects_apart():
    """Objects of one dataset share their velocities; each object's cache entries stay its own."""
    import numpy as np

    from hapticfx.data.bank import ProfileBank
    from hapticfx_neural.interpolator import VelocityCache

    v = np.array([2.0, 3.0, 4.0])
    t = np.arange(50) / 1000.0
    a = ProfileBank("a", "max-min", 1000.0, v, np.stack([np.sin(2 * np.pi * 40 * t) * k for k in (1, 2, 3)]))
    b = ProfileBank("b", "max-min", 1000.0, v, np.stack([np.cos(2 * np.pi * 90 * t) * k for k in (1, 2, 3)]))
    cache = VelocityCache(0.25)
    cache.add(a, lambda triples: np.full(triples.lower.shape, 1.0))   # stands in for the network
    cache.add(b, lambda triples: np.full(triples.lower.shape, -1.0))
    assert np.all(cache.lookup(a[0], a[1], 2.5) == 1.0)
    assert np.all(cache.lookup(b[0], b[1], 2.5) == -1.0)
    assert np.array_equal(cache.lookup(b[0], b[1], 2.0), b.profiles[0])  # interval ends: the recorded profiles
