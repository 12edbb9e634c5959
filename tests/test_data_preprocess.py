"""High-pass, resampling, trigger alignment and windows: stable and bounded at the edges."""

import numpy as np
import pytest

from hapticfx.processing.preprocess import Preprocessing, highpass, highpass_sos, preprocess, resample, trigger_onsets
from hapticfx.errors import SignalError

FS = 1000.0


def test_sos_is_stable_butterworth():
    sos = highpass_sos(FS, cutoff_hz=20.0, order=4)
    assert sos.shape == (2, 6)
    from scipy.signal import sos2zpk

    _, p, _ = sos2zpk(sos)
    assert np.all(np.abs(p) < 1.0)


def test_constant_input_gives_zero():
    out = highpass(np.full(1000, 1.0), FS)
    assert np.max(np.abs(out)) < 1e-9


def test_passband_and_stopband():
    t = np.arange(4000) / FS
    mid = slice(1000, 3000)
    low = highpass(np.sin(2 * np.pi * 3 * t), FS)
    high = highpass(np.sin(2 * np.pi * 150 * t), FS)
    assert np.max(np.abs(low[mid])) < 0.01  # 3 Hz: (3/20)^8 after forwards-backwards
    assert 0.99 < np.max(np.abs(high[mid])) < 1.01
    at_cut = highpass(np.sin(2 * np.pi * 20 * t), FS)
    assert np.max(np.abs(at_cut[mid])) == pytest.approx(0.5, abs=0.02)  # -3 dB twice


def test_step_is_finite_and_settles():
    x = np.r_[np.zeros(500), np.ones(1500)]
    out = highpass(x, FS)
    assert np.all(np.isfinite(out)) and np.max(np.abs(out)) < 1.5
    assert np.max(np.abs(out[-300:])) < 1e-3


def test_impulse_response_is_symmetric_zero_phase():
    x = np.zeros(2001)
    x[1000] = 1.0
    out = highpass(x, FS)
    np.testing.assert_allclose(out[1000 - 300:1000], out[1001:1001 + 300][::-1], atol=1e-9)
    assert np.argmax(np.abs(out)) == 1000


def test_full_scale_clipping_stays_bounded():
    t = np.arange(2000) / FS
    clipped = np.clip(10 * np.sin(2 * np.pi * 80 * t), -3.6, 3.6)
    out = highpass(clipped, FS)
    assert np.all(np.isfinite(out)) and np.max(np.abs(out)) < 2 * 3.6


@pytest.mark.parametrize("scale", [1e-12, 1e6])
def test_extreme_scales_are_linear(scale):
    rng = np.random.default_rng(0)
    x = rng.normal(size=(2, 1000))
    np.testing.assert_allclose(highpass(x * scale, FS), highpass(x, FS) * scale, rtol=1e-9, atol=1e-12 * scale)


def test_float64_reference_on_many_axes():
    from scipy.signal import sosfiltfilt

    rng = np.random.default_rng(2)
    xyz = rng.normal(size=(3, 800, 3)) + [0.0, 0.0, 1.0]
    out = highpass(xyz, FS, axis=-2)
    ref = sosfiltfilt(highpass_sos(FS), xyz, axis=-2)
    np.testing.assert_allclose(out, ref, atol=1e-12)


def test_cutoff_above_nyquist_is_rejected():
    with pytest.raises(SignalError, match="Nyquist"):
        highpass(np.zeros(100), 30.0)


@pytest.mark.parametrize("rate", [500.0, 2000.0, 3200.0, 44100.0 / 40])
def test_resample_keeps_a_sine(rate):
    n = int(rate)
    t = np.arange(n) / rate
    out = resample(np.sin(2 * np.pi * 50 * t), rate, 1000.0)
    assert out.shape[-1] == pytest.approx(1000, abs=2)
    tt = np.arange(out.shape[-1]) / 1000.0
    mid = slice(100, out.shape[-1] - 100)
    np.testing.assert_allclose(out[mid], np.sin(2 * np.pi * 50 * tt)[mid], atol=0.02)


def _drop(onset, n=1000, rate=FS):
    t = np.arange(n) / rate
    x = np.zeros((n, 3))
    x[:, 2] = 1.0
    dt = t - onset
    env = np.where(dt >= 0, np.exp(-np.clip(dt, 0, None) / 0.03), 0.0)
    x[:, 0] += 2.0 * env * np.sin(2 * np.pi * 100 * np.clip(dt, 0, None) + 0.5)
    x[:, 1] += 1.0 * env * np.sin(2 * np.pi * 170 * np.clip(dt, 0, None) + 1.0)
    return x


def test_trigger_alignment_lines_up_jittered_drops():
    drops = np.stack([_drop(o) for o in (0.2, 0.237, 0.31, 0.412)])
    w = preprocess(drops, FS)
    assert w.shape == (4, 500, 3)
    onsets = trigger_onsets(w)
    assert np.ptp(onsets) <= 1 and abs(int(onsets[0]) - 10) <= 2  # 10 ms pre-trigger
    np.testing.assert_allclose(w[0], w[1], atol=0.05)


def test_other_rates_are_resampled_to_1khz_windows():
    w_ref = preprocess(_drop(0.2), FS)
    w_2k = preprocess(_drop(0.2, n=2000, rate=2000.0), 2000.0)
    assert w_2k.shape == (500, 3)
    # The anti-alias filter smears the onset edge, so the trigger may fire one sample apart.
    best = min(np.max(np.abs(np.roll(w_2k, s, axis=0) - w_ref)[20:480]) for s in (-1, 0, 1))
    assert best < 0.01 * np.max(np.abs(w_ref))


def test_trigger_finds_the_onset_of_a_recording_whose_squares_overflow():
    xyz = np.zeros((50, 3))
    xyz[10], xyz[20] = 1e200, 3e200  # the squared magnitude overflowed to inf at both
    assert trigger_onsets(xyz, fraction=0.5) == 20


def test_silence_and_short_recordings():
    assert np.array_equal(preprocess(np.zeros((2, 300, 3)), FS), np.zeros((2, 500, 3)))
    w = preprocess(_drop(0.05, n=200), FS)  # shorter than a window: zero-padded
    assert w.shape == (500, 3) and np.all(w[200:] == 0.0)
    with pytest.raises(SignalError, match="at least 4"):
        preprocess(np.zeros((3, 3)), FS)
    assert preprocess(np.zeros((125, 3)), FS).shape == (500, 3)  # up to 4 times the recording: zeros
    with pytest.raises(SignalError, match="n_samples 500 is more than 4 times the recordings' length"):
        preprocess(np.zeros((124, 3)), FS)


def test_parameters_are_validated():
    with pytest.raises(SignalError, match="order"):
        Preprocessing(order=0)
    with pytest.raises(SignalError, match="n_samples"):
        Preprocessing(n_samples=2.5)
