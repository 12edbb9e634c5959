"""build_dataset: preprocessing, representatives (medoid + overrides), atomic writes, lazy reads."""

import json
import re

import numpy as np
import pytest

from hapticfx import hookspecs, registry
from hapticfx.data.build import ObjectRecordings, build_dataset, set_representative
from hapticfx.data.dataset import open_dataset
from hapticfx.data.training import recorded_drops
from hapticfx.interfaces import Reducer
from hapticfx.processing.preprocess import preprocess
from hapticfx.processing.reducers import dft321, max_min
from hapticfx.processing.representative import choose, medoid
from hapticfx.data.toy import toy_recordings
from hapticfx.errors import DatasetError, PluginError
from hapticfx.objects import PAPER_OBJECTS

V = [2.42, 3.13, 3.96]
META = dict(name="t", rate_hz=1000.0, sensor={"model": "synthetic"}, provenance={"source": "test"})


def _recs(**kw):
    return [toy_recordings(PAPER_OBJECTS[o], V, drops=4, seed=i, **kw)
            for i, o in enumerate(("wood-beam", "steel-plate"))]


def test_medoid_of_scaled_copies_is_the_middle_one():
    base = np.random.default_rng(0).normal(size=(500, 3))
    drops = np.stack([a * base for a in (1.2, 0.8, 1.0, 1.1, 0.9)])
    assert medoid(drops) == 2
    chosen, auto = choose(drops[None], [3.0], {3.0: 4})
    assert auto.tolist() == [2] and chosen.tolist() == [4]


def test_override_errors_name_object_and_velocity():
    w = np.zeros((2, 3, 10, 3))
    with pytest.raises(DatasetError, match=r"wood: representative override for 9.9 m/s, which is not recorded"):
        choose(w, [1.0, 2.0], {9.9: 0}, label="wood")
    with pytest.raises(DatasetError, match=r"must be a drop index 0..2, got 3"):
        choose(w, [1.0, 2.0], {2.0: 3}, label="wood")


def test_build_writes_raw_banks_and_metadata(tmp_path):
    recs = _recs()
    recs[0].representative_overrides = {3.13: 3}
    messages = []
    out = build_dataset(tmp_path / "ds", recs, progress=messages.append, **META)
    ds = open_dataset(out)
    assert sorted(ds.objects) == ["steel-plate", "wood-beam"] and ds.reducers() == ["dft321", "max-min"]
    assert ds.rate_hz == 1000.0 and ds.n_samples == 500 and ds.raw_rate_hz == 1000.0
    assert ds.meta["sensor"] == {"model": "synthetic"} and ds.meta["preprocessing"]["cutoff_hz"] == 20.0
    rep = ds.representatives("wood-beam")
    assert rep["overrides"] == [{"velocity_mps": 3.13, "drop": 3}] and rep["chosen"][1] == 3
    v, windows = ds.windows("wood-beam")
    for i in range(len(V)):
        assert rep["automatic"][i] == medoid(windows[i])
    picked = windows[np.arange(3), rep["chosen"]]
    np.testing.assert_allclose(ds.bank("wood-beam", "max-min").profiles, max_min(picked), atol=1e-5)
    np.testing.assert_allclose(ds.bank("wood-beam", "dft321").profiles, dft321(picked), atol=1e-5)
    with np.load(out / "banks" / "max-min" / "wood-beam.npz", allow_pickle=False) as z:
        assert z["representative"].tolist() == rep["chosen"]
    assert any("wood-beam" in m for m in messages)


def test_other_raw_rates_are_resampled(tmp_path):
    recs = [toy_recordings(PAPER_OBJECTS["wood-beam"], V, drops=3, rate_hz=2000.0)]
    ds = open_dataset(build_dataset(tmp_path / "ds", recs, **{**META, "rate_hz": 2000.0}))
    assert ds.raw_rate_hz == 2000.0 and ds.raw("wood-beam")[1].shape == (3, 3, 2000, 3)
    assert ds.bank("wood-beam", "max-min").profiles.shape == (3, 500)


def test_unsorted_velocities_are_sorted_with_their_drops():
    rec = toy_recordings(PAPER_OBJECTS["wood-beam"], V, drops=2)
    flipped = ObjectRecordings(rec.info, rec.velocities_mps[::-1], rec.accel_g[::-1])
    assert flipped.velocities_mps.tolist() == V
    np.testing.assert_array_equal(flipped.accel_g, rec.accel_g)


@pytest.mark.parametrize("velocities, shape, match", [
    ([2.0, 2.0], (2, 1, 100, 3), "recorded twice"),
    ([2.0, 3.0], (2, 1, 100, 2), r"shape \(2, drops, samples, 3\)"),
    ([0.0, 3.0], (2, 1, 100, 3), "must be > 0"),
    ([np.nan, 3.0], (2, 1, 100, 3), "non-finite"),
])
def test_bad_recordings_are_rejected(velocities, shape, match):
    with pytest.raises(DatasetError, match=match):
        ObjectRecordings(PAPER_OBJECTS["wood-beam"], np.array(velocities), np.zeros(shape))


def test_the_drops_of_one_height_are_recordings_but_not_a_dataset(tmp_path):
    """`data record` reads back one height's drops; a dataset needs two velocities to interpolate between."""
    one = ObjectRecordings(PAPER_OBJECTS["wood-beam"], np.array([2.0]), np.zeros((1, 1, 100, 3)))
    with pytest.raises(DatasetError, match="needs drops at 2 or more velocities"):
        build_dataset(tmp_path / "ds", [one], **META)
    assert list(tmp_path.iterdir()) == []


def test_failure_leaves_nothing_behind(tmp_path):
    def recordings():
        yield _recs()[0]
        raise DatasetError("recorder failed")

    with pytest.raises(DatasetError, match="recorder failed"):
        build_dataset(tmp_path / "ds", recordings(), **META)
    with pytest.raises(PluginError, match="unknown reducer 'nope'"):
        build_dataset(tmp_path / "ds", _recs(), reducers=("nope",), **META)
    with pytest.raises(DatasetError, match="recorder failed"):  # nor the folders it made for the dataset
        build_dataset(tmp_path / "new" / "sub" / "ds", recordings(), **META)
    assert list(tmp_path.iterdir()) == []


BAD_REDUCERS = {  # what a reducer plugin may wrongly return for windows (..., N, 3), and the words that say so
    "fx-short": (lambda xyz: xyz[..., :-1, 0], r"shape \(3, 499\)"),
    "fx-axes": (lambda xyz: xyz, r"shape \(3, 500, 3\)"),
    "fx-int": (lambda xyz: xyz[..., 0].astype(np.int64), "int64 values"),
    "fx-nan": (lambda xyz: np.full(xyz.shape[:-1], np.nan), r"\d+ non-finite value"),
    "fx-list": (lambda xyz: xyz[..., 0].tolist(), "a list"),
}


@pytest.fixture
def bad_reducers(monkeypatch):
    """The process registry with the core's plugins and the reducers of ``BAD_REDUCERS``."""
    class Plugin:
        @hookspecs.hookimpl
        def register_reducers(self, register):
            for name, (reduce, _) in BAD_REDUCERS.items():
                register(name, type("Bad", (Reducer,), {"name": name, "reduce": lambda self, xyz, f=reduce: f(xyz)}))

    pm, infos = registry.create_plugin_manager(entry_points=False)
    pm.register(Plugin(), name="fx-test-plugin")
    monkeypatch.setattr(registry, "_registry", registry.Registry(pm, infos))


@pytest.mark.parametrize("name", BAD_REDUCERS)
def test_a_reducer_returning_the_wrong_profiles_builds_nothing(tmp_path, bad_reducers, name):
    out = tmp_path / "ds"
    with pytest.raises(PluginError) as err:
        build_dataset(out, _recs(), reducers=("max-min", name), **META)
    message = str(err.value)
    assert message.startswith(f"{out}: reducer '{name}' returned ") and "object 'wood-beam'" in message
    assert re.search(BAD_REDUCERS[name][1], message) and "expected finite float64 values of shape (3, 500)" in message
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", BAD_REDUCERS)
def test_a_reducer_returning_the_wrong_drops_is_refused_naming_the_dataset(tmp_path, bad_reducers, name):
    ds = open_dataset(build_dataset(tmp_path / "ds", _recs()[:1], reducers=("max-min",), **META))
    with pytest.raises(PluginError, match=rf"^{re.escape(str(ds.path))}: reducer '{name}' returned .*object "
                                          r"'wood-beam'.*expected finite float64 values of shape \(3, 4, 500\)"):
        recorded_drops(ds, "wood-beam", name)


def test_overwrite_is_explicit_and_atomic(tmp_path):
    build_dataset(tmp_path / "ds", _recs(), **META)
    with pytest.raises(DatasetError, match="already exists"):
        build_dataset(tmp_path / "ds", _recs(), **META)
    build_dataset(tmp_path / "ds", _recs()[:1], overwrite=True, **META)
    assert open_dataset(tmp_path / "ds").objects == ["wood-beam"]
    assert [p.name for p in tmp_path.iterdir()] == ["ds"]


def test_reading_one_object_reads_only_its_files(tmp_path):
    out = build_dataset(tmp_path / "ds", _recs(), **META)
    for f in out.rglob("steel-plate.npz"):
        f.unlink()
    ds = open_dataset(out)
    assert ds.bank("wood-beam", "max-min").profiles.shape == (3, 500)
    assert ds.raw("wood-beam")[1].shape[0] == 3
    with pytest.raises(DatasetError, match="file not found"):
        ds.raw("steel-plate")


def test_set_representative_stores_override_and_rebuilds(tmp_path):
    out = build_dataset(tmp_path / "ds", _recs(), **META)
    ds = open_dataset(out)
    auto = ds.representatives("steel-plate")["automatic"][2]
    other = (auto + 1) % 4
    set_representative(out, "steel-plate", 3.96, other)
    ds2 = open_dataset(out)
    assert ds2.representatives("steel-plate")["chosen"][2] == other
    _, w = ds2.windows("steel-plate")
    np.testing.assert_allclose(ds2.bank("steel-plate", "max-min").profiles[2], max_min(w[2, other]), atol=1e-5)
    assert ds2.meta["provenance"] == {"source": "test"}
    set_representative(out, "steel-plate", 3.96, None)
    assert open_dataset(out).representatives("steel-plate")["overrides"] == []
    with pytest.raises(DatasetError, match="no drops at 9"):
        set_representative(out, "steel-plate", 9.0, 1)


def test_metadata_is_json_without_pickle(tmp_path):
    out = build_dataset(tmp_path / "ds", _recs(), **META)
    meta = json.loads((out / "dataset.json").read_text())
    assert meta["representative_method"].startswith("medoid")
    for f in out.rglob("*.npz"):
        with np.load(f, allow_pickle=False) as z:
            assert all(z[k].dtype != object for k in z.files)


def test_windows_match_preprocess_of_raw(tmp_path):
    out = build_dataset(tmp_path / "ds", _recs(), **META)
    ds = open_dataset(out)
    v, raw = ds.raw("wood-beam")
    np.testing.assert_allclose(ds.windows("wood-beam")[1], preprocess(raw, 1000.0))


def test_dataset_directory_is_not_private(tmp_path):
    import os
    import stat

    out = build_dataset(tmp_path / "ds", _recs(), **META)
    umask = os.umask(0o022)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o777 & ~umask


def test_a_velocity_from_a_drop_height_is_picked_as_it_is_printed(tmp_path):
    """`data record --height-m 0.7995` records sqrt(2 g h) = 3.959943... m/s: the 4 decimals that messages print
    pick it (it was matched within 1e-6 and printed with %g, so that no typed value could)."""
    v = float(np.sqrt(2 * 9.80665 * 0.7995))
    path = build_dataset(tmp_path / "ds", [toy_recordings(PAPER_OBJECTS["wood-beam"], [3.1, v], drops=3)], name="h",
                         rate_hz=1000.0, sensor={}, provenance={})
    set_representative(path, "wood-beam", 3.9599, 2)
    rep = open_dataset(path).meta["objects"]["wood-beam"]["representative"]["overrides"]
    assert rep == [{"velocity_mps": v, "drop": 2}]
    with pytest.raises(DatasetError, match=r"wood-beam has no drops at 3\.959 m/s; recorded: 3\.1, 3\.9599$"):
        set_representative(path, "wood-beam", 3.959, 1)
