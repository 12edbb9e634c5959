"""Built-in models at the edges: hand-computed kinetic energy, data-driven exactness and continuity."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.errors import SignalError
from hapticfx.interfaces import Impact
from hapticfx.pipeline import Pipeline

from hfx_testdata import VELOCITIES, tiny_profiles


def ke_effect(write_effect, **model):
    return Pipeline.from_effect(write_effect({
        "name": "ke", "object": "concrete-brick", "velocity_mps": 3.8,
        "model": {"type": "kinetic-energy", **model}, "actuator": {"type": "memory"},
    }), device="memory")


@pytest.mark.parametrize("v, expected", [
    (3.8, 0.5 * 0.069 * 3.8**2 / 2.0),        # 0.249090 by hand
    (0.0, 0.0),
    (1.0, 0.5 * 0.069 / 2.0),                 # 0.01725
    (7.6, 1.0),                               # 0.9964 ... just under
    (20.0, 1.0),                              # clipped
])
def test_kinetic_energy_amplitude_by_hand(write_effect, v, expected):
    p = ke_effect(write_effect, ke_max_j=2.0, pulse_ms=25)
    prof = p.model.render(Impact("concrete-brick", v)).samples
    amp = min(expected, 1.0) if v != 7.6 else 0.5 * 0.069 * 7.6**2 / 2.0
    assert prof[0] == 0.0
    assert np.all(prof[1:26] == pytest.approx(amp, rel=1e-12))
    assert np.all(prof[26:] == 0.0)
    assert prof.shape == (500,)


def test_kinetic_energy_other_object_and_mass_override(write_effect):
    p = ke_effect(write_effect, ke_max_j=1.0)
    steel = p.model.render(Impact("steel-plate", 2.0)).samples.max()
    assert steel == pytest.approx(0.5 * 0.2 * 4.0)
    p2 = ke_effect(write_effect, ke_max_j=1.0, mass_kg=10.0)
    assert p2.model.render(Impact("concrete-brick", 1.0)).samples.max() == pytest.approx(1.0)


def dd_pipeline(write_effect, dataset, **model):
    return Pipeline.from_effect(write_effect({
        "name": "dd", "object": "concrete-brick", "velocity_mps": 3.3,
        "model": {"type": "data-driven", "dataset": str(dataset), **model},
        "actuator": {"type": "memory"},
    }), device="memory")


def test_recorded_velocity_returns_recorded_profile_exactly(write_effect, tiny_dataset):
    p = dd_pipeline(write_effect, tiny_dataset)
    expected = tiny_profiles(VELOCITIES)
    for i, v in enumerate(VELOCITIES):
        assert np.array_equal(p.model.render(Impact("concrete-brick", v)).samples, expected[i])


@pytest.mark.parametrize("side", [-1, 1])
def test_continuity_towards_recorded_velocity(write_effect, tiny_dataset, side):
    p = dd_pipeline(write_effect, tiny_dataset)
    expected = tiny_profiles(VELOCITIES)
    for i, v in enumerate(VELOCITIES[1:-1], start=1):
        near = p.model.render(Impact("concrete-brick", v + side * 1e-6)).samples
        jump = np.max(np.abs(near - expected[i]))
        assert jump < 1e-4 * np.max(np.abs(expected[i]))


def test_between_is_weighted_average(write_effect, tiny_dataset):
    p = dd_pipeline(write_effect, tiny_dataset)
    prof = tiny_profiles(VELOCITIES)
    v = 2.42 + 0.25 * (2.80 - 2.42)
    out = p.model.render(Impact("concrete-brick", v)).samples
    assert np.allclose(out, 0.75 * prof[0] + 0.25 * prof[1], atol=1e-12)


@pytest.mark.parametrize("v", [0.0, 0.5, 2.0, 4.5, 10.0, 20.0])
def test_outside_range_policies(write_effect, tiny_dataset, v):
    prof = tiny_profiles(VELOCITIES)
    edge = 0 if v < VELOCITIES[0] else -1
    scaled = dd_pipeline(write_effect, tiny_dataset).model.render(Impact("concrete-brick", v)).samples
    assert np.allclose(scaled, prof[edge] * v / VELOCITIES[edge])
    clamped = dd_pipeline(write_effect, tiny_dataset, outside="clamp").model.render(Impact("concrete-brick", v)).samples
    assert np.array_equal(clamped, prof[edge])
    with pytest.raises(SignalError, match="outside the recorded range"):
        dd_pipeline(write_effect, tiny_dataset, outside="refuse").model.render(Impact("concrete-brick", v))
    note, = dd_pipeline(write_effect, tiny_dataset).render(velocity=v).notes
    assert f"{v:g} m/s is outside the recorded" in note and "scaled by velocity" in note


@pytest.mark.parametrize("v", [VELOCITIES[0], (VELOCITIES[0] + VELOCITIES[1]) / 2, VELOCITIES[-1]])
def test_no_note_at_or_between_recorded_velocities(write_effect, tiny_dataset, v):
    assert dd_pipeline(write_effect, tiny_dataset).render(velocity=v).notes == ()


def test_whole_pipeline_output_bounded_for_any_velocity(write_effect, tiny_dataset):
    p = dd_pipeline(write_effect, tiny_dataset)
    for v in np.concatenate([np.linspace(0, 20, 41), np.array(VELOCITIES)]):
        d = p.render(velocity=float(v))
        assert np.all(np.isfinite(d.output.samples))
        assert d.output.peak <= p.limits.peak + 1e-12
        assert d.output.rate_hz == p.actuator.spec.rate_hz


@pytest.mark.parametrize("v", [float("nan"), float("inf"), -1.0])
def test_bad_velocity_rejected_at_the_gate(write_effect, tiny_dataset, v):
    with pytest.raises(SignalError):
        dd_pipeline(write_effect, tiny_dataset).render(velocity=v)


def test_corrupt_bank_is_a_clear_error(write_effect, tiny_dataset):
    from hapticfx.errors import DatasetError

    (tiny_dataset / "banks" / "max-min" / "concrete-brick.npz").write_bytes(b"not a zip")
    with pytest.raises(DatasetError, match="concrete-brick.npz: corrupt or unreadable") as err:
        dd_pipeline(write_effect, tiny_dataset)
    # numpy takes such bytes for pickled data and says how to load them unsafely: not advice to pass on
    assert "pickle" not in str(err.value) and "not an .npz archive of plain arrays" in str(err.value)


def test_unknown_object_in_dataset(write_effect, tiny_dataset):
    from hapticfx.errors import DatasetError

    p = dd_pipeline(write_effect, tiny_dataset)
    with pytest.raises(DatasetError, match="dataset 'tiny' has no object 'wood-beam'; it has: concrete-brick"):
        p.render(velocity=3.0, object="wood-beam")


def test_recorded_drops_are_preprocessed_once_per_version_of_the_dataset(tmp_path):
    """A study's scene holds one recorded model per drop it plays: they share one preprocessing of the object's
    drops, read-only, and a raw file rewritten on disk is read again."""
    import shutil

    from hapticfx.data.dataset import resolve_dataset_path
    from hapticfx.models.recorded import RecordedDropModel
    from hapticfx.params import BuildContext

    folder = tmp_path / "drops"
    shutil.copytree(resolve_dataset_path("builtin:helmet-drops"), folder)
    context = BuildContext(object_id="steel-plate")
    first, third = (RecordedDropModel(RecordedDropModel.Params(dataset=str(folder), drop=d), context) for d in (0, 2))
    velocities, drops = first.drops("steel-plate")
    assert third.drops("steel-plate")[1] is drops and not drops.flags.writeable
    v = float(velocities[0])
    assert np.array_equal(third.profile("steel-plate", v), drops[0, 2]) and not np.array_equal(drops[0, 0], drops[0, 2])

    raw = folder / "raw" / "steel-plate.npz"
    arrays = dict(np.load(raw))
    arrays["accel_g"] = arrays["accel_g"][:, ::-1].copy()  # the same drops in the reverse order
    np.savez(raw, **arrays)
    again = third.drops("steel-plate")[1]
    assert again is not drops and np.array_equal(again[0, 2], drops[0, drops.shape[1] - 3])
