"""Velocity tables: exact where the method is affine, within tolerance elsewhere, stale tables refused."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.data.bank import ProfileBank
from hapticfx.errors import CheckpointError
from hapticfx.interpolators.residual import compose, weight
from hapticfx.interpolators.table import VelocityTable, bank_digest, build_table

V = np.array([2.0, 2.5, 3.1, 4.0])


def _bank(obj="brick", k=1.0, n=64):
    t = np.arange(n) / 1000.0
    prof = np.stack([k * v * np.exp(-40 * t) * np.sin(2 * np.pi * (50 + 10 * v) * t) for v in V])
    return ProfileBank(obj, "max-min", 1000.0, V, prof)


def affine(lower, upper, v_lo, v_hi, v, obj):
    w = weight(v_lo, v_hi, v)[:, None]
    return 0.3 * (upper - lower) / 5 + w * np.cos(np.arange(lower.shape[1]) / 7.0)[None]


def curved(lower, upper, v_lo, v_hi, v, obj):
    w = weight(v_lo, v_hi, v)[:, None]
    return np.sin(6.0 * w + np.arange(lower.shape[1])[None] / 9.0)


def _table(fn, banks, **kw):
    return build_table(banks, fn, interpolator="test", source={"weights_sha256": "abc"}, dataset="tiny", **kw)


def _direct(fn, bank, v):
    i = int(np.searchsorted(bank.velocities, v, side="right")) - 1
    lo, hi = bank[i], bank[i + 1]
    r = fn(lo.samples[None], hi.samples[None], np.array([lo.velocity]), np.array([hi.velocity]), np.array([v]), bank.object)
    return lo, hi, compose(lo.samples, hi.samples, weight(lo.velocity, hi.velocity, v), r[0])


def test_the_residual_form_returns_the_neighbours_exactly_and_scales_by_their_larger_peak():
    rng = np.random.default_rng(3)
    lower, upper, r = rng.standard_normal((3, 40))
    assert np.array_equal(compose(lower, upper, 0.0, r * 1e6), lower)
    assert np.array_equal(compose(lower, upper, 1.0, r * 1e6), upper)
    s = max(np.abs(lower).max(), np.abs(upper).max())
    assert np.allclose(compose(lower, upper, 0.5, r), 0.5 * (lower + upper) + s * r)
    silent = np.zeros(40)
    assert np.allclose(compose(silent, silent, 0.5, r), r)  # silent neighbours: scale 1, no division by zero


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_an_affine_residual_needs_two_nodes_and_is_exact(dtype):
    bank = _bank()
    bank = ProfileBank(bank.object, bank.reducer, bank.rate_hz, bank.velocities, bank.profiles.astype(dtype))
    table = _table(affine, [bank])
    assert table.n_nodes == 2 * (len(V) - 1)
    table.attach(bank, rebuild="rebuild it")
    rng = np.random.default_rng(0)
    for v in rng.uniform(V[0], V[-1], 300):
        lo, hi, direct = _direct(affine, bank, v)
        got = table.lookup(lo, hi, v)
        assert np.max(np.abs(got - direct)) <= 1e-12 * np.abs(direct).max()


def test_a_curved_residual_is_refined_until_within_tolerance():
    bank = _bank()
    table = _table(curved, [bank], tolerance=1e-7)
    assert table.n_nodes > 2 * (len(V) - 1)
    table.attach(bank, rebuild="x")
    rng = np.random.default_rng(1)
    for v in rng.uniform(V[0], V[-1], 500):
        lo, hi, direct = _direct(curved, bank, v)
        peak = max(np.abs(lo.samples).max(), np.abs(hi.samples).max())
        assert np.max(np.abs(table.lookup(lo, hi, v) - direct)) <= 1e-7 * peak


def test_recorded_neighbours_come_back_exactly_and_unknown_ones_miss():
    bank = _bank()
    table = _table(curved, [bank])
    table.attach(bank, rebuild="x")
    for i in range(len(V) - 1):
        lo, hi = bank[i], bank[i + 1]
        assert np.array_equal(table.lookup(lo, hi, lo.velocity), lo.samples)
        assert np.array_equal(table.lookup(lo, hi, hi.velocity), hi.samples)
    other = _bank(k=2.0)
    assert table.lookup(other[0], other[1], 2.2) is None


def test_objects_sharing_velocities_are_told_apart(tmp_path):
    a, b = _bank("b", 1.0), _bank("a", -3.0)  # not in sorted order
    table = VelocityTable.load(_table(affine, [a, b]).save(tmp_path / "t.table.npz"))
    table.attach(a, rebuild="x")
    table.attach(b, rebuild="x")
    for bank in (a, b):
        lo, hi, direct = _direct(affine, bank, 2.2)
        assert np.allclose(table.lookup(lo, hi, 2.2), direct, rtol=0, atol=1e-12)


def test_a_residual_that_never_settles_is_refused():
    rng = np.random.default_rng(2)

    def noisy(lower, upper, v_lo, v_hi, v, obj):
        return rng.standard_normal(lower.shape)

    with pytest.raises(CheckpointError, match="not smooth enough to tabulate"):
        _table(noisy, [_bank()])


def test_a_rough_interval_is_tabulated_in_the_smoother_form_its_method_names():
    bank = _bank()
    rough = {1}  # interval 1's residual jumps in w until the method switches it to a smooth form
    told = []

    def fn(lower, upper, v_lo, v_hi, v, obj):
        w = weight(v_lo, v_hi, v)[:, None]
        jumps = np.isclose(v_lo, bank.velocities[1])[:, None] & (1 in rough)
        return np.where(jumps & (w > 0.37), 1.0, 0.0) + curved(lower, upper, v_lo, v_hi, v, obj)

    def on_rough(obj, i):
        told.append((obj, i))
        rough.discard(i)

    table = _table(fn, [bank], tolerance=1e-6, on_rough=on_rough)
    assert told == [("brick", 1)]
    table.attach(bank, rebuild="x")
    v = float(np.mean(bank.velocities[1:3]))
    lo, hi, direct = _direct(fn, bank, v)
    assert np.abs(table.lookup(lo, hi, v) - direct).max() <= 1e-6 * np.abs(bank.profiles).max()
    rough.add(1)

    def still_rough(obj, i):
        told.append((obj, i))

    with pytest.raises(CheckpointError, match="not smooth enough to tabulate"):  # once only, then refused
        _table(fn, [bank], tolerance=1e-6, on_rough=still_rough)


def test_file_round_trip_and_stale_tables_are_refused(tmp_path):
    bank = _bank()
    path = _table(curved, [bank]).save(tmp_path / "t.table.npz")
    table = VelocityTable.load(path)
    table.check_source("test", {"weights_sha256": "abc"}, rebuild="rebuild")
    table.attach(bank, rebuild="rebuild")
    lo, hi, direct = _direct(curved, bank, 3.3)
    assert np.allclose(table.lookup(lo, hi, 3.3), direct, atol=1e-8)
    with pytest.raises(CheckpointError, match=r"t.table.npz: stale: built for weights_sha256 'abc', now 'def'; do it"):
        table.check_source("test", {"weights_sha256": "def"}, rebuild="do it")
    with pytest.raises(CheckpointError, match="a table of interpolator 'test', not 'other'"):
        table.check_source("other", {}, rebuild="x")
    changed = ProfileBank(bank.object, bank.reducer, bank.rate_hz, bank.velocities, bank.profiles * 1.001)
    assert bank_digest(changed) != bank_digest(bank)
    with pytest.raises(CheckpointError, match="stale: the bank of 'brick' changed"):
        table.attach(changed, rebuild="x")
    with pytest.raises(CheckpointError, match="no table for object 'wood'"):
        table.attach(_bank("wood"), rebuild="x")
    dft = ProfileBank(bank.object, "dft321", bank.rate_hz, bank.velocities, bank.profiles)
    with pytest.raises(CheckpointError, match="built for reducer 'max-min' banks, not 'dft321'"):
        table.attach(dft, rebuild="x")


def test_corrupt_and_foreign_files_are_refused(tmp_path):
    path = _table(affine, [_bank()]).save(tmp_path / "t.table.npz")
    data = path.read_bytes()
    bad = tmp_path / "truncated.table.npz"
    bad.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match="truncated.table.npz: corrupt or unreadable velocity table"):
        VelocityTable.load(bad)
    with pytest.raises(CheckpointError, match="missing.npz: velocity table not found"):
        VelocityTable.load(tmp_path / "missing.npz")
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, meta_json=np.array('{"format": "other"}'))
    with pytest.raises(CheckpointError, match="not a hapticfx-interpolator-table file"):
        VelocityTable.load(foreign)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["o0.w"] = arrays["o0.w"][::-1].copy()
    broken = tmp_path / "broken.table.npz"
    np.savez(broken, **arrays)
    with pytest.raises(CheckpointError, match="broken.table.npz: malformed velocity table .*nodes from 0 to 1"):
        VelocityTable.load(broken)


def test_a_table_weighs_its_nodes_by_the_pull_and_keeps_the_bumps_node_counts(tmp_path):
    import json

    from hapticfx.interpolators.residual import lift

    bank = _bank()
    table = _table(affine, [bank], pull_power=4)
    assert table.n_nodes == 2 * (len(V) - 1) and table.meta["pull"] == 4 == table.pull  # an affine residual: 2 nodes
    assert "pull" not in _table(affine, [bank]).meta  # the bump: as every table before the pull
    back = VelocityTable.load(table.save(tmp_path / "p.table.npz"))
    back.attach(bank, rebuild="x")
    for v in np.linspace(2.0, 4.0, 17):
        i = min(int(np.searchsorted(V, v, side="right")) - 1, len(V) - 2)
        lo, hi = bank[i], bank[i + 1]
        w = weight(lo.velocity, hi.velocity, v)
        r = affine(lo.samples[None], hi.samples[None], np.array([lo.velocity]), np.array([hi.velocity]),
                   np.array([v]), bank.object)[0]
        expected = compose(lo.samples, hi.samples, w, lift(w, 4) * r)  # 1 - |1 - 2w|^4 toward the residual
        assert np.allclose(back.lookup(lo, hi, float(v)), expected, rtol=0, atol=1e-12)
    with np.load(tmp_path / "p.table.npz") as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta_json"]))
    meta["pull"] = 3
    arrays["meta_json"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "odd.table.npz", **arrays)
    with pytest.raises(CheckpointError, match="odd.table.npz: malformed velocity table .*even number >= 2, got 3"):
        VelocityTable.load(tmp_path / "odd.table.npz")
    with pytest.raises(ValueError, match="even number >= 2, got 5"):
        _table(affine, [bank], pull_power=5)


def test_shared_tables_reads_a_file_once_until_it_changes(tmp_path):
    from hapticfx.interpolators.table import shared_tables

    path = _table(affine, [_bank()]).save(tmp_path / "t.table.npz")
    assert VelocityTable.load(path) is not VelocityTable.load(path)  # outside: a table per load
    with shared_tables():
        first = VelocityTable.load(path)
        assert VelocityTable.load(path) is first
        _table(curved, [_bank()]).save(path)  # rewritten: another size, another modification time
        assert VelocityTable.load(path) is not first
    assert VelocityTable.load(path) is not VelocityTable.load(path)


def test_an_engine_reads_the_table_its_entries_share_once(monkeypatch):
    """The four entries of the earthquake room, each served from the built-in dataset's ensemble-warp table,
    each read it (4 x 6 ms at start); they render what entries built one by one render."""
    from pathlib import Path

    from hapticfx.engine import Engine
    from hapticfx.pipeline import Pipeline

    reads, np_load = [], np.load

    def counted(file, *args, **kwargs):
        reads.append(Path(file).name)
        return np_load(file, *args, **kwargs)

    monkeypatch.setattr(np, "load", counted)
    scene = Path(__file__).resolve().parents[1] / "scenes" / "earthquake_room.yaml"
    with Engine(scene, device="memory") as engine:
        assert reads.count("ensemble-warp-max-min.table.npz") == 1
        for oid, pipeline in engine._pipelines.items():
            alone = Pipeline(pipeline.effect, device="memory")
            for v in (2.2, 3.3, 5.1):
                assert np.array_equal(pipeline.render(velocity=v).output.samples,
                                      alone.render(velocity=v).output.samples), (oid, v)
