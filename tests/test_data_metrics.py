"""Spectral, temporal and peak match: definitions, fixed points and edge cases."""

import numpy as np
import pytest

from hapticfx.processing.metrics import match, peak_match, spectral_match, temporal_match, welch_spectral_match
from hapticfx.processing.preprocess import preprocess
from hapticfx.processing.reducers import dft321, max_min
from hapticfx.data.toy import toy_recordings
from hapticfx.errors import SignalError
from hapticfx.objects import PAPER_OBJECTS


@pytest.fixture(scope="module")
def windows():
    rec = toy_recordings(PAPER_OBJECTS["wood-beam"], [2.42, 3.96], drops=5, seed=4)
    return preprocess(rec.accel_g, 1000.0).reshape(-1, 500, 3)


def test_match_definition():
    assert match([1.0, 2.0], [1.0, 2.0]) == 1.0
    assert match([1.0, 0.0], [0.0, 1.0]) == 0.0
    assert match([0.0, 0.0], [0.0, 0.0]) == 1.0
    # 1 - (|3-1| + |1-1|) / (3+1+1+1) = 1 - 2/6
    assert match([3.0, 1.0], [1.0, 1.0]) == pytest.approx(2.0 / 3.0)


def test_dft321_spectral_match_is_one_by_construction(windows):
    s = spectral_match(dft321(windows), windows)
    np.testing.assert_allclose(s, 1.0, atol=1e-12)


def test_max_min_scores_below_dft321_spectrally_but_not_perfect_temporally(windows):
    mm, d = max_min(windows), dft321(windows)
    assert np.all(spectral_match(mm, windows) < 0.999)
    assert np.all(temporal_match(d, windows) < 0.999)  # phase from the summed spectrum moves energy in time
    for fn in (spectral_match, welch_spectral_match, temporal_match):
        v = fn(mm, windows)
        assert np.all((v >= 0) & (v <= 1))


def test_single_axis_scores_one_for_dft321():
    rng = np.random.default_rng(0)
    xyz = np.zeros((500, 3))
    xyz[:, 1] = rng.normal(size=500)
    x = dft321(xyz)
    for fn in (spectral_match, welch_spectral_match, temporal_match):
        assert fn(x, xyz) == pytest.approx(1.0, abs=1e-9)
    assert peak_match(x, xyz) == pytest.approx(1.0)


def test_temporal_match_compares_envelopes_not_signs():
    rng = np.random.default_rng(1)
    xyz = np.zeros((500, 3))
    xyz[:, 0] = rng.normal(size=500)
    assert temporal_match(-xyz[:, 0], xyz) == pytest.approx(1.0)
    late = np.roll(xyz[:, 0] * np.exp(-np.arange(500) / 20.0), 250)
    xyz[:, 0] = xyz[:, 0] * np.exp(-np.arange(500) / 20.0)
    assert temporal_match(late, xyz) < 0.1


def test_zero_signals_and_scale_invariance(windows):
    z = np.zeros((500, 3))
    assert spectral_match(np.zeros(500), z) == 1.0 and temporal_match(np.zeros(500), z) == 1.0
    assert peak_match(np.zeros(500), z) == 1.0
    x = max_min(windows[:2])
    for fn in (spectral_match, temporal_match, welch_spectral_match):
        np.testing.assert_allclose(fn(x * 1e6, windows[:2] * 1e6), fn(x, windows[:2]), rtol=1e-9)
        np.testing.assert_allclose(fn(x * 1e-12, windows[:2] * 1e-12), fn(x, windows[:2]), rtol=1e-9)


def test_peak_match_of_max_min_is_the_kept_fraction():
    xyz = np.zeros((10, 3))
    xyz[3] = [3.0, 4.0, 0.0]  # magnitude 5, max-min keeps 4
    assert peak_match(max_min(xyz), xyz) == pytest.approx(0.8)


def test_shapes_are_checked():
    with pytest.raises(SignalError, match="must be"):
        spectral_match(np.zeros(400), np.zeros((500, 3)))
    with pytest.raises(SignalError, match="no frequency bin"):
        spectral_match(np.zeros(500), np.zeros((500, 3)), band_hz=(600.0, 700.0))
