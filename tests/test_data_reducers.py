"""max-min (paper Eq. 8) and DFT321: hand-computed cases and the properties that must hold."""

import numpy as np
import pytest

from hapticfx.processing.reducers import DFT321, MaxMin, dft321, max_min
from hapticfx.errors import SignalError
from hapticfx.registry import get_registry


def test_max_min_picks_the_sign_per_eq8():
    xyz = np.array([
        [1.0, -2.0, 0.5],    # one axis >= 0: the maximum
        [0.2, 5.0, -7.0],    # the maximum even though |min| is larger
        [-1.0, 0.0, -3.0],   # zero counts as >= 0: max is 0
        [-3.0, -1.0, -2.0],  # all negative: the minimum
        [-0.1, -0.2, -9.0],
        [0.0, 0.0, 0.0],
    ])
    assert max_min(xyz).tolist() == [1.0, 5.0, 0.0, -3.0, -9.0, 0.0]


def test_max_min_matches_a_loop_reference_on_random_batches():
    rng = np.random.default_rng(1)
    xyz = rng.normal(size=(4, 7, 50, 3))
    ref = np.empty(xyz.shape[:-1])
    for idx in np.ndindex(*xyz.shape[:-1]):
        a = xyz[idx]
        ref[idx] = max(a) if (a[0] >= 0 or a[1] >= 0 or a[2] >= 0) else min(a)
    np.testing.assert_array_equal(max_min(xyz), ref)


def test_dft321_hand_computed():
    # X = [2, 0], Y = [0, 2]: |A| = [2, 2], angle(X + Y) = [0, 0] -> irfft = [2, 0]
    xyz = np.array([[1.0, 1.0, 0.0], [1.0, -1.0, 0.0]])
    np.testing.assert_allclose(dft321(xyz), [2.0, 0.0], atol=1e-15)
    # X = [1, 1], Y = -X: the summed spectrum is 0, np.angle(0) = 0 -> irfft([sqrt2, sqrt2]) = [sqrt2, 0]
    xyz = np.array([[1.0, -1.0, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(dft321(xyz), [np.sqrt(2.0), 0.0], atol=1e-15)


def test_dft321_keeps_the_sign_of_a_negative_dc_signal():
    # Sum spectrum [-2, 0]: np.angle gives pi; a bare arctan(Im/Re) would give 0 and flip the sign.
    xyz = np.array([[-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    np.testing.assert_allclose(dft321(xyz), [-1.0, -1.0], atol=1e-15)


@pytest.mark.parametrize("n", [1, 2, 7, 500, 501])
def test_dft321_keeps_length_and_rss_spectrum(n):
    rng = np.random.default_rng(n)
    xyz = rng.normal(size=(3, n, 3)) * [1.0, 0.3, 5.0]
    out = dft321(xyz)
    assert out.shape == (3, n)
    rss = np.sqrt(np.sum(np.abs(np.fft.rfft(xyz, axis=-2)) ** 2, axis=-1))
    np.testing.assert_allclose(np.abs(np.fft.rfft(out, axis=-1)), rss, rtol=1e-9, atol=1e-9)
    # Parseval: DFT321 keeps the total energy of the three axes.
    np.testing.assert_allclose(np.sum(out ** 2, axis=-1), np.sum(xyz ** 2, axis=(-2, -1)), rtol=1e-9)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_single_axis_input_comes_back_unchanged(axis):
    rng = np.random.default_rng(axis)
    xyz = np.zeros((500, 3))
    xyz[:, axis] = rng.normal(size=500) * 3.0
    np.testing.assert_allclose(dft321(xyz), xyz[:, axis], atol=1e-12)


def test_zeros_give_zeros():
    z = np.zeros((2, 500, 3))
    assert np.array_equal(dft321(z), np.zeros((2, 500)))
    assert np.array_equal(max_min(z), np.zeros((2, 500)))


@pytest.mark.parametrize("scale", [1e-12, 1.0, 1e6])
def test_reducers_finite_and_linear_at_extreme_scales(scale):
    rng = np.random.default_rng(3)
    xyz = rng.normal(size=(500, 3))
    for fn in (dft321, max_min):
        out = fn(xyz * scale)
        assert np.all(np.isfinite(out))
        np.testing.assert_allclose(out, fn(xyz) * scale, rtol=1e-9, atol=1e-9 * scale)


@pytest.mark.parametrize("scale", [1e153, 1e200, 2.0 ** 1000, 1e306])
def test_dft321_finite_and_linear_beyond_where_its_squares_overflow(scale):
    # The float64 reference is the same signal reduced at an ordinary scale, then scaled.
    xyz = np.random.default_rng(3).normal(size=(2, 500, 3)) / 4
    out = dft321(xyz * scale)
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(out, dft321(xyz) * scale, rtol=1e-9, atol=1e-9 * scale)
    assert np.array_equal(dft321(np.stack([xyz[0], xyz[1] * scale]))[0], dft321(xyz[0]))  # each signal by itself


@pytest.mark.parametrize("scale", [1e-150, 1e-200, 1e-300])
def test_dft321_finite_and_linear_where_its_squares_would_underflow(scale):
    """A 1e-300 signal reduced to exactly 0 (its squared spectra underflowed), where sqrt(3) c is the answer for a
    constant c on every axis."""
    xyz = np.random.default_rng(3).normal(size=(2, 500, 3)) / 4
    np.testing.assert_allclose(dft321(xyz * scale), dft321(xyz) * scale, rtol=1e-9, atol=1e-9 * scale)
    assert np.array_equal(dft321(np.stack([xyz[0] * scale, xyz[1]]))[1], dft321(xyz[1]))  # each signal by itself
    assert dft321(np.full((8, 3), 1e-300)) == pytest.approx(np.full(8, np.sqrt(3) * 1e-300), rel=1e-12)


def test_dft321_of_no_samples_is_no_samples():
    assert dft321(np.zeros((0, 3))).shape == (0,) and dft321(np.zeros((2, 0, 3))).shape == (2, 0)


def test_dft321_of_the_largest_floats():
    top = np.finfo(np.float64).max
    one_axis = np.zeros((4, 3))
    one_axis[0, 0] = top
    np.testing.assert_allclose(dft321(one_axis), [top, 0.0, 0.0, 0.0], rtol=1e-12, atol=1e-12 * top)
    with pytest.raises(SignalError, match="dft321 of a signal peaking at 1.8e\\+308 exceeds the float64 range"):
        dft321(np.full((4, 3), top))  # sqrt(3) * top has no float64


def test_dft321_of_the_builtin_drops_is_the_shipped_bank():
    from hapticfx.data.dataset import open_dataset

    ds = open_dataset("builtin:helmet-drops")
    for obj in ds.objects:
        velocities, windows = ds.windows(obj)
        picked = windows[np.arange(len(velocities)), ds.representatives(obj)["chosen"]]
        assert np.array_equal(dft321(picked), ds.bank(obj, "dft321").profiles)  # bit for bit: banks have digests


def test_reducers_validate_input():
    for fn in (dft321, max_min):
        with pytest.raises(SignalError, match=r"\(\.\.\., samples, 3\)"):
            fn(np.zeros((10, 2)))
        with pytest.raises(SignalError, match="non-finite"):
            fn(np.full((10, 3), np.nan))
        with pytest.raises(SignalError, match="real numbers"):
            fn(np.zeros((10, 3), complex))


def test_registered_under_their_names():
    reg = get_registry()
    assert isinstance(reg.create("reducer", "max-min"), MaxMin)
    assert isinstance(reg.create("reducer", "dft321"), DFT321)
    xyz = np.random.default_rng(0).normal(size=(5, 100, 3))
    np.testing.assert_array_equal(reg.create("reducer", "dft321").reduce(xyz), dft321(xyz))
