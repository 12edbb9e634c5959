"""Impact families beyond falling objects: each effect validates and renders sensibly at its edges."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hapticfx.effect import check_effect, load_effect
from hapticfx.pipeline import Pipeline

FAMILIES = sorted((Path(__file__).resolve().parents[1] / "effects" / "families").glob("*.yaml"))
EXPECTED = {"bat_ball", "football_kick", "tapping", "wheel_bump", "tapping_rubber", "tapping_wood", "tapping_aluminium"}
TABLES = FAMILIES[0].parent / "tables"


def top(pipeline, factor=3.0):
    return min(factor * pipeline.effect.velocity_mps, pipeline.model.params.max_velocity_mps)


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
        for v in (0.0, 0.05 * v0, v0, top(pipeline)):
            d = pipeline.impact(velocity=v)
            for sig in (d.profile, d.output):
                assert np.all(np.isfinite(sig.samples))
            assert d.output.peak <= pipeline.limits.peak + 1e-12
            peaks[v] = d.profile.peak
    assert peaks[0.0] == 0.0, "no velocity, no impact"
    assert peaks[0.05 * v0] > 0.0
    assert peaks[0.05 * v0] < peaks[v0] < peaks[top(pipeline)]


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
    for v in (v0, top(pipeline)):
        p = pipeline.render(velocity=v).profile.samples
        assert np.abs(p[-len(p) // 20:]).max() < 0.02 * np.abs(p).max(), v


@pytest.mark.parametrize("path", FAMILIES, ids=lambda p: p.stem)
def test_family_is_served_from_its_shipped_table(path):
    """Opening a family reads its table from effects/families/tables/: no ODE is solved when it opens or plays."""
    pipeline = Pipeline.from_effect(path, device="memory")
    model = pipeline.model
    table = model.table_for(model.object_for(pipeline.effect.object_id))
    assert table.table.path.parent == TABLES, "rebuild it: python -m hapticfx bench physics (see docs/families.md)"


def test_each_family_has_its_own_receiver_and_renders_the_side_the_user_feels():
    models = {p.stem: load_effect(p).model.options for p in FAMILIES}
    receivers = {models[f]["receiver"] for f in ("bat_ball", "football_kick", "tapping", "wheel_bump")}
    assert receivers == {"bat-handle", "boot", "tabletop", "car-seat"}
    assert {f for f, m in models.items() if m["felt"] == "striker"} == {f for f in models if f.startswith("tapping")}


def test_the_dominant_ringing_frequencies_of_the_four_families_differ():
    """docs/images/families-spectra.png: each struck body's spectrum peaks at its own frequency (>= 20 % apart)."""
    from hapticfx.bench.families import FOUR, receiver_spectrum

    peaks = sorted(receiver_spectrum(stem)[3] for stem in FOUR)
    assert all(b > 1.2 * a for a, b in zip(peaks, peaks[1:])), peaks
