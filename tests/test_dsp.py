"""The playback path's numpy DSP against scipy's float64 reference designs."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from hapticfx.actuators.files import read_wav, write_wav
from hapticfx.dsp import butterworth_power, resample_poly, zero_phase_butterworth
from hapticfx.shaping import band_limit, resample
from hapticfx.signal import Signal


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("up, down", [(48, 1), (441, 10), (1, 3), (3, 2), (160, 147), (1, 1)])
def test_resample_matches_scipy(dtype, up, down):
    x = np.random.default_rng(up * 1000 + down).standard_normal((2, 500)).astype(dtype)
    ours = resample_poly(x, up, down)
    ref = ss.resample_poly(x.astype(np.float64), up, down, axis=-1)
    assert ours.shape == ref.shape and ours.dtype == np.float64
    assert np.max(np.abs(ours - ref)) < 1e-12


@pytest.mark.parametrize("low, high", [(20, None), (None, 800), (30, 800), (20, 15000)])
def test_butterworth_power_matches_scipy_design(low, high):
    fs = 48000
    band = [low, high] if low and high else (low or high)
    kind = "bandpass" if low and high else ("highpass" if low else "lowpass")
    f, h = ss.sosfreqz(ss.butter(2, band, kind, fs=fs, output="sos"), worN=4096, fs=fs)
    assert np.max(np.abs(butterworth_power(f, fs, low_hz=low, high_hz=high, order=2) - np.abs(h) ** 2)) < 1e-9


def test_zero_phase_filter_agrees_with_sosfiltfilt_on_an_impact():
    fs = 48000
    t = np.arange(24000) / fs
    onset = t > 0.1
    x = onset * np.exp(-(t - 0.1) * 40) * np.sin(2 * np.pi * 180 * (t - 0.1))
    ours = zero_phase_butterworth(x, fs, low_hz=30, high_hz=800)
    ref = ss.sosfiltfilt(ss.butter(2, [30, 800], "bandpass", fs=fs, output="sos"), x)
    assert np.max(np.abs(ours - ref)) < 1e-3 * np.max(np.abs(x))
    lag = np.argmax(ss.correlate(ours, x, mode="full", method="fft")) - (x.size - 1)
    assert lag == 0  # zero phase


@pytest.mark.parametrize("value", [0.0, 1e-12, 1.0, 1e6])
def test_shaping_is_finite_and_linear_at_extreme_levels(value):
    sig = Signal(np.full(500, value), 1000.0)
    out = band_limit(resample(sig, 48000), (20.0, 15000.0))
    assert out.rate_hz == 48000 and np.all(np.isfinite(out.samples))
    unit = band_limit(resample(Signal(np.ones(500), 1000.0), 48000), (20.0, 15000.0))
    # FFT rounding is relative to the largest sample, so the tolerance scales with the level
    assert np.allclose(out.samples, unit.samples * value, rtol=1e-9, atol=1e-12 * value * np.abs(unit.samples).max())


@pytest.mark.parametrize("fmt, step", [("pcm16", 1 / 32767), ("pcm24", 1 / 8388607), ("float32", 6e-8)])
def test_wav_writer_reads_back_within_one_step(tmp_path, fmt, step):
    import wave

    x = np.random.default_rng(1).uniform(-1, 1, (2, 1000))
    write_wav(tmp_path / "a.wav", x, 48000, fmt=fmt)
    rate, data = read_wav(tmp_path / "a.wav")
    assert rate == 48000 and data.shape == (2, 1000)
    assert np.max(np.abs(data - x)) <= step
    if fmt != "float32":  # the standard library's reader takes every PCM file hapticfx writes
        with wave.open(str(tmp_path / "a.wav")) as w:
            assert (w.getnchannels(), w.getframerate(), w.getnframes()) == (2, 48000, 1000)