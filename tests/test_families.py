"""Impact families beyond falling objects: each effect validates and renders sensibly at its edges."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hapticfx.effect import check_effect, load_effect
from hapticfx.pipeline import Pipeline
from hapticfx.signal import MAX_VELOCITY_MPS

FAMILIES = sorted((Path(__file__).resolve().parents[1] / "effects" / "families").glob("*.yaml"))
EXPECTED = {"bat_ball", "football_kick", "tapping", "wheel_bump"}


def test_the_four_families_exist():
    assert EXPECTED <= {p.stem for p in FAMILIES}


@pytest.mark.parametrize("path", FAMILIES, ids=lambda p: p.stem)
def test_family_validates_with_the_contact_model(path):
    effect = load_effect(path)
    check_effect(effect)
    assert effect.model.type == "contact"
    assert effect.object_info is not None and effect.object_info.mass_kg > 0


@pytest.mark.parametrize("path", FAMILIES, ids=lambda p: p.stem)
def test_family_renders_finite_bounded_and_grows_with_velocity(path):
    pipeline = Pipeline.from_effect(path, device="memory")
    v0 = pipeline.effect.velocity_mps
    peaks = {}
    with pipeline:
        for v in (0.0, 0.05 * v0, v0, min(3.0 * v0, MAX_VELOCITY_MPS)):
            d = pipeline.impact(velocity=v)
            for sig in (d.profile, d.output):
                assert np.all(np.isfinite(sig.samples))
            assert d.output.peak <= pipeline.limits.peak + 1e-12
            peaks[v] = d.profile.peak
    assert peaks[0.0] == 0.0, "no velocity, no impact"
    assert peaks[0.05 * v0] > 0.0
    assert peaks[0.05 * v0] < peaks[v0] < peaks[min(3.0 * v0, MAX_VELOCITY_MPS)]


@pytest.mark.parametrize("path", FAMILIES, ids=lambda p: p.stem)
def test_default_velocity_is_felt_and_not_clipped(path):
    """The effect's full_scale_g suits its default impact: clearly present, within the limits untouched."""
    pipeline = Pipeline.from_effect(path, device="memory")
    d = pipeline.render()
    assert 0.05 < d.output.peak < pipeline.limits.peak
    assert d.limiter.total == 0


@pytest.mark.parametrize("path", FAMILIES, ids=lambda p: p.stem)
def test_the_profile_has_died_away_before_it_ends(path):
    """No family is cut off mid-bounce: the last 5% of the profile is quiet at and above its default speed."""
    pipeline = Pipeline.from_effect(path, device="memory")
    v0 = pipeline.effect.velocity_mps
    for v in (v0, min(3.0 * v0, MAX_VELOCITY_MPS)):
        p = pipeline.render(velocity=v).profile.samples
        assert np.abs(p[-len(p) // 20:]).max() < 0.02 * np.abs(p).max(), v
