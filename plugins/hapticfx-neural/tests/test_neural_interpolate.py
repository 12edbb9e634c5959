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


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_table_equals_direct_inference_and_returns_the_neighbours_exactly(trained, syn_dataset):
    ds = open_dataset(syn_dataset)
    direct = get_registry().create("interpolator", "convbilstm", weights=str(trained), cache=False)
    tabled = get_registry().create("interpolator", "convbilstm", weights=str(trained))
    rng = np.random.default_rng(0)
    for obj in ds.objects:
        bank = ds.bank(obj, "max-min")
        direct.prepare(bank, dataset=ds)
        tabled.prepare(bank, dataset=ds)
        assert tabled.net is None and tabled.table is not None  # served from numbers
        for v in rng.uniform(bank.velocities[0], bank.velocities[-1], 1000):
            v = float(v)
            if bank.index_of(v) is not None:
                continue
            lo, hi = bank.neighbours(v)
            assert _rel(tabled.interpolate(lo, hi, v), direct.interpolate(lo, hi, v)) <= 1e-6
        for i in range(len(bank) - 1):
            lo, hi = bank[i], bank[i + 1]
            for interp in (direct, tabled):
                assert np.array_equal(interp.interpolate(lo, hi, lo.velocity), lo.samples)
                assert np.array_equal(interp.interpolate(lo, hi, hi.velocity), hi.samples)


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
    for k, r in enumerate(bank.velocities[1:-1], start=1):
        assert np.array_equal(model.profile("plastic-frame", float(r)), bank.profiles[k])
        for side in (-1e-9, 1e-9):  # endpoint-consistent by construction: no jump at a recorded velocity
            assert _rel(model.profile("plastic-frame", float(r) + side), bank.profiles[k]) <= 1e-6


def test_stale_or_missing_tables_are_refused_and_rebuilt(tmp_path, trained, syn_dataset):
    import json
    import shutil
    import subprocess
    import sys

    from hapticfx.errors import CheckpointError
    from hapticfx_neural import checkpoint

    ck = tmp_path / "ck"
    shutil.copytree(trained.parent, ck)
    ds = open_dataset(syn_dataset)
    bank = ds.bank("plastic-frame", "max-min")

    def serve():
        interp = get_registry().create("interpolator", "convbilstm", weights=str(ck))
        interp.prepare(bank, dataset=ds)
        return interp

    serve()
    table = checkpoint.table_path(ck / "model.safetensors")
    old = table.read_bytes()
    # weights retrained without a new table: the JSON's digest no longer matches the table's source
    meta = json.loads((ck / "model.json").read_text())
    meta["weights_sha256"] = ("0" if meta["weights_sha256"][0] != "0" else "1") + meta["weights_sha256"][1:]
    (ck / "model.json").write_text(json.dumps(meta))
    with pytest.raises(CheckpointError, match=r"model.table.npz: stale: built for weights_sha256 .*"
                                              r"rebuild it with `hapticfx table .*ck`"):
        serve()
    shutil.copy(trained.with_suffix(".json"), ck / "model.json")
    table.unlink()
    with pytest.raises(CheckpointError, match=r"model.table.npz: velocity table not found; "
                                              r"rebuild it with `hapticfx table .*ck`"):
        serve()
    r = subprocess.run([sys.executable, "-m", "hapticfx", "table", str(ck)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and table.is_file() and table.read_bytes() != b""
    serve()
    assert len(old) > 0


def test_weights_that_do_not_match_their_json_are_refused(tmp_path, trained, syn_dataset):
    import shutil

    from hapticfx.errors import CheckpointError

    ck = tmp_path / "ck"
    shutil.copytree(trained.parent, ck)
    data = bytearray((ck / "model.safetensors").read_bytes())
    data[-1] ^= 0x01
    (ck / "model.safetensors").write_bytes(bytes(data))
    interp = get_registry().create("interpolator", "convbilstm", weights=str(ck), cache=False)
    ds = open_dataset(syn_dataset)
    with pytest.raises(CheckpointError, match="the weights do not match model.json"):
        interp.prepare(ds.bank("plastic-frame", "max-min"), dataset=ds)


@pytest.mark.parametrize("cache", [False, True])
def test_a_table_renders_from_shaped_atoms_and_direct_inference_does_not(trained, syn_dataset, cache):
    from hapticfx.interfaces import ActuatorSpec, Impact
    from hapticfx.models.datadriven import DataDrivenModel
    from hapticfx.params import BuildContext
    from hapticfx.shaping import ShapedAtoms, shape

    params = DataDrivenModel.Params(dataset=str(syn_dataset), interpolator="convbilstm",
                                    interpolator_options={"weights": str(trained), "cache": cache})
    model = DataDrivenModel(params, BuildContext(object_id="plastic-frame"))
    spec = ActuatorSpec(rate_hz=48000.0, volts_peak=5.0, band_hz=(20.0, 15000.0))
    atoms = ShapedAtoms(gain=0.8, scale=0.25)
    bank = model.bank("plastic-frame")
    between = (bank.velocities[1:] + bank.velocities[:-1]) / 2
    for v in np.concatenate([[0.5 * bank.velocities[0]], bank.velocities, between, [2 * bank.velocities[-1]]]):
        impact = Impact("plastic-frame", float(v))
        terms = model.terms(impact)
        inside = bank.velocities[0] < v < bank.velocities[-1] and v not in bank.velocities
        if inside and not cache:
            assert terms is None  # the network runs per impact: its answer is no fixed sum
            continue
        ref = shape(model.render(impact), spec, gain=0.8, scale=0.25).samples
        got = atoms.shape(terms, spec).samples
        assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
