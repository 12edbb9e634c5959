"""The ensemble interpolator: drop centres, endpoint consistency, fitted tables shipped with datasets."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from hapticfx.data.build import ObjectRecordings, build_dataset
from hapticfx.data.dataset import open_dataset
from hapticfx.data.toy import toy_recordings
from hapticfx.data.training import training_data
from hapticfx.errors import CheckpointError, DatasetError
from hapticfx.interpolators.ensemble import TRIMS, EnsembleInterpolator, centres, choose_trim, fit_table, table_path
from hapticfx.models.datadriven import DataDrivenModel
from hapticfx.objects import PAPER_OBJECTS
from hapticfx.params import BuildContext

V = [2.42, 2.80, 3.13, 3.43, 3.70]
META = dict(name="ens", rate_hz=1000.0, sensor={"model": "synthetic"}, provenance={"source": "test"})


@pytest.fixture
def dataset(tmp_path):
    recs = [toy_recordings(PAPER_OBJECTS[o], V, drops=6, seed=i) for i, o in enumerate(("wood-beam", "steel-plate"))]
    return open_dataset(build_dataset(tmp_path / "ds", recs, **META))


def _model(ds, **options):
    params = DataDrivenModel.Params(dataset=str(ds.path), interpolator="ensemble", interpolator_options=options)
    return DataDrivenModel(params, BuildContext(object_id="wood-beam"))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_centres_are_trimmed_means_over_the_drops(dtype):
    drops = np.arange(2 * 10 * 3, dtype=dtype).reshape(2, 10, 3)[:, ::-1] ** 2
    assert np.allclose(centres(drops, 0.0), drops.mean(axis=1))
    assert np.allclose(centres(drops, 0.4), np.median(drops, axis=1))  # 10 drops: the middle two
    assert np.allclose(centres(drops[:, :3], 0.4), np.median(drops[:, :3], axis=1))  # 3 drops: the middle one
    assert np.allclose(centres(drops[:, :1], 0.4), drops[:, 0])


def test_datasets_carry_their_fitted_tables(dataset):
    for reducer in ("max-min", "dft321"):
        assert table_path(dataset.path, reducer).is_file()
    model = _model(dataset)
    assert model.describe()["served_from"]["table"] == str(table_path(dataset.path, "max-min"))
    table_path(dataset.path, "max-min").unlink()
    refit = _model(dataset)  # no table: fitted at load from raw/, to the same numbers
    assert refit.describe()["served_from"]["table"] == "velocity table"
    trim = model.interpolator.table.meta["source"]["trim"]
    assert refit.describe()["trim"] == trim
    other = _model(dataset, trim=0.4 if trim < 0.4 else 0.0)
    assert not np.allclose(other.profile("wood-beam", 3.0), model.profile("wood-beam", 3.0))
    for v in np.linspace(V[0], V[-1], 57):
        a, b = model.profile("wood-beam", float(v)), refit.profile("wood-beam", float(v))
        assert np.allclose(a, b, rtol=0, atol=1e-12)


def test_recorded_velocities_exact_no_jump_and_bounded_everywhere(dataset):
    model = _model(dataset)
    bank = model.bank("wood-beam")
    peak = np.abs(bank.profiles).max()
    for k, r in enumerate(bank.velocities):
        assert np.array_equal(model.profile("wood-beam", float(r)), bank.profiles[k])
        for side in (-1e-9, 1e-9):
            if bank.velocities[0] < r + side < bank.velocities[-1]:
                jump = np.abs(model.profile("wood-beam", float(r) + side) - bank.profiles[k]).max()
                assert jump <= 1e-6 * np.abs(bank.profiles[k]).max()
    for v in np.concatenate([[0.0, 1e-9], np.linspace(0, 20, 201)]):
        out = model.profile("wood-beam", float(v))  # above the range: the top profile scaled by v / v_top
        assert np.all(np.isfinite(out)) and np.abs(out).max() <= 2 * peak * max(1.0, v / bank.velocities[-1])


def test_halfway_the_profile_is_the_blend_of_the_drop_centres(dataset):
    model = _model(dataset)
    trim = model.interpolator.table.meta["source"]["trim"]
    bank = model.bank("wood-beam")
    velocities, drops = training_data(dataset, "max-min", ["wood-beam"]).drops["wood-beam"]
    c = centres(drops, trim)
    mid = 0.5 * (bank.velocities[1] + bank.velocities[2])
    assert np.allclose(model.profile("wood-beam", float(mid)), 0.5 * (c[1] + c[2]), rtol=0, atol=1e-12)


def test_the_trim_is_chosen_on_training_data_only(dataset):
    full = training_data(dataset, "max-min")
    held = training_data(dataset, "max-min", holdout={"wood-beam": [3.13], "steel-plate": [3.13]})
    assert 3.13 not in held.banks["wood-beam"].velocities
    assert 3.13 not in held.drops["wood-beam"][0] and held.drops["wood-beam"][1].shape[0] == len(V) - 1
    trim, scores = choose_trim(held)
    assert trim in TRIMS and set(scores) == set(TRIMS)
    assert scores != choose_trim(full)[1]
    table = fit_table(held)
    assert table.meta["objects"]["wood-beam"]["velocities"] == [v for v in V if v != 3.13]


def test_a_stale_table_is_refused_with_the_command_that_rewrites_it(dataset, tmp_path):
    other = open_dataset(build_dataset(tmp_path / "other", [toy_recordings(PAPER_OBJECTS["wood-beam"], V, drops=6,
                                                                           seed=9)], **META))
    table_path(dataset.path, "max-min").write_bytes(table_path(other.path, "max-min").read_bytes())
    with pytest.raises(CheckpointError, match=r"ensemble-max-min.table.npz: stale: the bank of 'wood-beam' changed"
                                              r".*hapticfx data tables DATASET"):
        _model(dataset)
    r = subprocess.run([sys.executable, "-m", "hapticfx", "data", "tables", str(dataset.path)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for name in ("ensemble", "ensemble-warp"):
        assert f"{name} interpolator (max-min): trim" in r.stderr and f"{name} interpolator (dft321): trim" in r.stderr
    _model(dataset).profile("wood-beam", 3.0)


def test_a_dataset_without_recorded_drops_is_refused_clearly(tiny_dataset):
    params = DataDrivenModel.Params(dataset=str(tiny_dataset), interpolator="ensemble")
    with pytest.raises(DatasetError, match=r"needs every recorded drop; dataset 'tiny' keeps only representative "
                                           r"profiles of concrete-brick .*use interpolator: linear"):
        DataDrivenModel(params, BuildContext(object_id="concrete-brick"))


def test_unprepared_neighbours_are_refused():
    from hapticfx.errors import SignalError
    from hapticfx.interfaces import Profile

    interp = EnsembleInterpolator()
    with pytest.raises(SignalError, match="no fitted drops for the neighbours"):
        interp.interpolate(Profile(2.0, np.ones(8)), Profile(3.0, np.ones(8)), 2.5)


def test_datasets_of_different_velocities_per_object(tmp_path):
    recs = [toy_recordings(PAPER_OBJECTS["wood-beam"], [2.0, 2.6, 3.3, 4.1], drops=5, seed=1),
            toy_recordings(PAPER_OBJECTS["steel-plate"], [2.2, 3.0, 3.5, 3.9, 4.6, 5.0], drops=7, seed=2)]
    assert all(isinstance(r, ObjectRecordings) for r in recs)
    ds = open_dataset(build_dataset(tmp_path / "mixed", recs, **META))
    params = DataDrivenModel.Params(dataset=str(ds.path), interpolator="ensemble")
    model = DataDrivenModel(params, BuildContext(object_id="steel-plate"))
    for obj in ds.objects:
        bank = model.bank(obj)
        for v in np.linspace(bank.velocities[0], bank.velocities[-1], 23):
            assert np.all(np.isfinite(model.profile(obj, float(v))))
