"""Rendering from shaped atoms: a model that answers with Terms renders what shaping its profile gives.

Shaping is linear, so the pipeline shapes each atom once and sums; these tests
hold that sum against shaping the model's own profile (float64) at velocities
below, at, between and above the recorded ones.
"""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.errors import SignalError
from hapticfx.interfaces import ActuatorSpec, Impact, Term, Terms
from hapticfx.pipeline import Pipeline
from hapticfx.safety import SafetyLimiter
from hapticfx.shaping import ShapedAtoms, shape

EFFECTS = ["effects/falling_brick_kinetic.yaml", "effects/falling_brick_linear.yaml", "effects/falling_brick.yaml"]


def velocities(pipeline: Pipeline) -> list[float]:
    bank = getattr(pipeline.model, "bank", None)
    recorded = bank(pipeline.effect.object_id).velocities if bank else np.array([1.0, 3.8, 6.0])
    lo, hi = float(recorded[0]), float(recorded[-1])
    mids = (recorded[1:] + recorded[:-1]) / 2
    rng = np.random.default_rng(0)
    return [0.0, lo / 2, *map(float, recorded), *map(float, mids), *map(float, rng.uniform(lo, hi, 20)),
            hi * 1.5, 100.0]


def reference(pipeline: Pipeline, v: float) -> np.ndarray:
    profile = pipeline.model.render(Impact(pipeline.effect.object_id, v))
    return shape(profile, pipeline.actuator.spec, gain=pipeline.gain, scale=pipeline.scale).samples


@pytest.mark.parametrize("path", EFFECTS)
def test_atoms_sum_to_the_shaped_profile(path):
    pipeline = Pipeline.from_effect(path, device="memory")
    atoms = ShapedAtoms(gain=pipeline.gain, scale=pipeline.scale)
    for v in velocities(pipeline):
        terms = pipeline.model.terms(Impact(pipeline.effect.object_id, v))
        assert terms is not None
        got = atoms.shape(terms, pipeline.actuator.spec)
        ref = reference(pipeline, v)
        assert got.rate_hz == pipeline.actuator.spec.rate_hz and got.samples.shape == ref.shape
        assert np.all(np.isfinite(got.samples))
        assert np.max(np.abs(got.samples - ref)) <= 1e-12 * max(np.max(np.abs(ref)), 1e-300), v
        assert np.array_equal(terms.profile().samples, pipeline.model.render(Impact(pipeline.effect.object_id, v)).samples)


@pytest.mark.parametrize("path", EFFECTS)
def test_pipeline_render_is_the_limited_shaped_profile(path):
    for v in (0.3, 3.8, 4.123, 9.0):
        pipeline = Pipeline.from_effect(path, device="memory")
        out = pipeline.render(velocity=v).output.samples
        expected = SafetyLimiter(pipeline.limits, pipeline.actuator.spec.rate_hz).process(reference(pipeline, v))
        assert np.max(np.abs(out - expected)) <= 1e-12


def test_opening_shapes_every_atom_so_impacts_only_sum(monkeypatch):
    import hapticfx.shaping as shaping

    pipeline = Pipeline.from_effect("effects/falling_brick.yaml", device="memory")
    with pipeline:
        calls = []
        monkeypatch.setattr(shaping, "shape", lambda *a, **k: calls.append(a) or shape(*a, **k))
        for v in velocities(pipeline):
            pipeline.render(velocity=v)
        assert calls == []  # every atom was shaped when the effect opened


def test_cache_is_bounded_and_answers_the_same_after_eviction():
    spec = ActuatorSpec(rate_hz=48000.0, volts_peak=5.0, band_hz=(20.0, 15000.0))
    rng = np.random.default_rng(1)
    rows = [rng.normal(size=500) for _ in range(6)]
    small = ShapedAtoms(gain=0.8, scale=0.5, max_bytes=2 * 24000 * 8)  # two shaped atoms
    for _ in range(3):
        for i in range(5):
            terms = Terms(1000.0, (Term(i, 0.3, rows[i]), Term(i + 1, -1.7, rows[i + 1])))
            got = small.shape(terms, spec).samples
            ref = shape(terms.profile(), spec, gain=0.8, scale=0.5).samples
            assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
            assert small._bytes <= small.max_bytes


def test_another_spec_reshapes_the_atoms():
    row = np.zeros(500)
    row[10:40] = 1.0
    terms = Terms(1000.0, (Term("pulse", 0.5, row),))
    atoms = ShapedAtoms(gain=1.0, scale=1.0)
    for rate, band in ((48000.0, (20.0, 15000.0)), (44100.0, (30.0, 800.0)), (48000.0, (20.0, 15000.0))):
        spec = ActuatorSpec(rate_hz=rate, volts_peak=5.0, band_hz=band)
        got = atoms.shape(terms, spec)
        ref = shape(terms.profile(), spec, gain=1.0, scale=1.0)
        assert got.rate_hz == ref.rate_hz and np.array_equal(got.samples, ref.samples)


@pytest.mark.parametrize("items, message", [
    ((), "at least one term"),
    ((Term("a", 1.0, np.zeros(5)), Term("b", 1.0, np.zeros(6))), "one length"),
    ((Term("a", 1.0, np.zeros((2, 5))),), "1D"),
    ((Term("a", float("nan"), np.zeros(5)),), "weight of term 'a' must be finite"),
])
def test_terms_refuse_what_cannot_be_summed(items, message):
    with pytest.raises(SignalError, match=message):
        Terms(1000.0, items)
