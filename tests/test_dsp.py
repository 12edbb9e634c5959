"""The playback path's numpy DSP against scipy's float64 reference designs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.signal as ss

from hapticfx.actuators.files import read_wav, write_wav
from hapticfx.dsp import causal_butterworth, rate_ratio, resample_poly, resample_rate, taper
from hapticfx.interfaces import ActuatorSpec
from hapticfx.shaping import shape
from hapticfx.signal import Signal

VIBRO = ActuatorSpec(48000.0, 5.0, (20.0, 15000.0))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("up, down", [(48, 1), (441, 10), (1, 3), (3, 2), (160, 147), (1, 1)])
def test_resample_matches_scipy(dtype, up, down):
    x = np.random.default_rng(up * 1000 + down).standard_normal((2, 500)).astype(dtype)
    ours = resample_poly(x, up, down)
    ref = ss.resample_poly(x.astype(np.float64), up, down, axis=-1)
    assert ours.shape == ref.shape and ours.dtype == np.float64
    assert np.max(np.abs(ours - ref)) < 1e-12


@pytest.mark.parametrize("from_hz, to_hz", [(2400.0, 1000.0), (1000.0, 44100.0), (1000.0, 1000.0), (1e6, 1000.0)])
def test_resample_rate_along_any_axis_matches_scipy(from_hz, to_hz):
    x = np.random.default_rng(7).standard_normal((3, 600, 2))  # time on the middle axis, as a dataset has it
    ratio = rate_ratio(from_hz, to_hz)
    ref = ss.resample_poly(x, ratio.numerator, ratio.denominator, axis=1)
    ours = resample_rate(x, from_hz, to_hz, axis=1)
    assert ours.shape == ref.shape and np.max(np.abs(ours - ref)) < 1e-12


def test_a_ratio_that_rounds_to_zero_is_refused():
    with pytest.raises(ValueError, match="cannot resample from 1e\\+06 Hz to 0.1 Hz"):
        resample_rate(np.ones(10), 1e6, 0.1)


def test_a_ratio_past_a_thousand_to_one_is_refused_not_approximated():
    """1.5 MHz to 1 kHz was taken as 1000:1, a recording 50 % too long."""
    with pytest.raises(ValueError, match="past 1000 to 1"):
        resample_rate(np.ones(1500), 1.5e6, 1000.0)
    assert resample_rate(np.ones(100_000), 1e6, 1000.0).shape == (100,)


@pytest.mark.parametrize("rate", [1001.0, 997.3, 1234.567])
def test_a_profile_at_an_odd_rate_comes_out_at_the_actuators(rate, tmp_path):
    """The ratio's rate is within RATE_PPM of 48 kHz: the shaped signal is at 48 kHz, so a WAV takes it."""
    from hapticfx.actuators.files import write_wav
    from hapticfx.shaping import RATE_PPM

    exact = float(rate * rate_ratio(rate, 48000.0))
    assert abs(exact - 48000.0) <= RATE_PPM * 1e-6 * 48000.0
    out = shape(Signal(np.hanning(int(rate) // 2), rate), VIBRO, gain=1.0, scale=0.1)
    assert out.rate_hz == 48000.0
    write_wav(tmp_path / "x.wav", out.samples, out.rate_hz)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("fs, low, high", [(1000, 20, None), (1000, None, 300), (1000, 30, 400), (48000, 20, 15000)])
def test_causal_butterworth_equals_lfilter_of_scipys_design(dtype, fs, low, high):
    t = np.arange(2000) / fs
    x = ((t > 0.05) * np.exp(-(t - 0.05) * 40) * np.sin(2 * np.pi * 180 * (t - 0.05))).astype(dtype)
    ref = x.astype(np.float64)
    for edge, kind in ((low, "highpass"), (high, "lowpass")):
        if edge:
            ref = ss.lfilter(*ss.butter(2, edge, kind, fs=fs), ref)
    ours = causal_butterworth(x, fs, low_hz=low, high_hz=high)
    assert ours.dtype == np.float64 and np.max(np.abs(ours - ref)) < 1e-9 * max(1.0, np.max(np.abs(ref)))
    assert np.max(np.abs(ours[: int(0.05 * fs)])) < 1e-12  # causal: nothing before the onset


@pytest.mark.parametrize("fs, low, high", [(41, 20, None), (45, 20, None), (1000, None, 400), (1000, None, 470),
                                          (1000, 20, 400)])
def test_causal_butterworth_near_nyquist_does_not_wrap_round(fs, low, high):
    """An edge near Nyquist puts a pole near -1 that rings much longer than 1 / (2 pi edge): a signal still
    loud at its end must not wrap its filtered tail round onto its start."""
    x = np.zeros(40)
    x[1:31] = 1.0
    ref = x
    for edge, kind in ((low, "highpass"), (high, "lowpass")):
        if edge:
            ref = ss.lfilter(*ss.butter(2, edge, kind, fs=fs), ref)
    ours = causal_butterworth(x, fs, low_hz=low, high_hz=high)
    assert np.max(np.abs(ours - ref)) < 1e-8 and abs(ours[0]) < 1e-8  # the tail left at e**-20


def test_taper_starts_and_ends_at_zero_and_leaves_the_middle():
    x = np.ones((2, 1000))
    y = taper(x, 1000.0, fade_in_s=0.002, fade_out_s=0.01)
    assert np.all(y[:, 0] == 0.0) and np.all(y[:, -1] < 0.03) and np.all(y[:, 2:990] == 1.0)
    assert np.all(np.diff(y[0, :3]) > 0) and np.all(np.diff(y[0, -11:]) < 0)
    assert np.array_equal(taper(x[:, :3], 1000.0, fade_in_s=1.0, fade_out_s=1.0)[:, 1], [1.0, 1.0])


@pytest.mark.parametrize("value", [0.0, 1e-12, 1.0, 1e6])
def test_shaping_is_finite_and_linear_at_extreme_levels(value):
    sig = Signal(np.full(500, value), 1000.0)
    out = shape(sig, VIBRO, gain=1.0, scale=1.0)
    assert out.rate_hz == 48000 and np.all(np.isfinite(out.samples))
    unit = shape(Signal(np.ones(500), 1000.0), VIBRO, gain=1.0, scale=1.0)
    # FFT rounding is relative to the largest sample, so the tolerance scales with the level
    assert np.allclose(out.samples, unit.samples * value, rtol=1e-9, atol=1e-12 * value * np.abs(unit.samples).max())


def test_a_pulse_actuator_gets_the_profile_without_band_limit_or_fades():
    pulse = np.zeros(500)
    pulse[:30] = 0.7
    out = shape(Signal(pulse, 1000.0), ActuatorSpec(1000.0, 12.0, (0.0, 500.0), waveform=False), gain=1.0, scale=1.0)
    assert np.array_equal(out.samples, pulse)  # a solenoid reads the 30 ms width


@pytest.mark.parametrize("spec", [VIBRO, ActuatorSpec(48000.0, 5.0, (30.0, 800.0))])
def test_shaped_output_starts_and_ends_at_zero(spec):
    """A square pulse from the first sample (the kinetic-energy model) and a profile cut off mid-vibration."""
    square = np.zeros(500)
    square[:30] = 1.0
    cut = np.sin(2 * np.pi * 60 * np.arange(500) / 1000.0)
    for profile in (square, cut):
        out = shape(Signal(profile, 1000.0), spec, gain=1.0, scale=1.0).samples
        assert abs(out[0]) < 1e-3 and abs(out[-1]) < 1e-3, (out[0], out[-1])


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

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted(p for pattern in ("effects/*.yaml", "effects/families/*.yaml", "plugins/*/effects/*.yaml")
                 for p in ROOT.glob(pattern))


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_effect_starts_and_ends_at_zero(path):
    from hapticfx.pipeline import Pipeline

    pipeline = Pipeline.from_effect(path, device="memory")
    top = getattr(pipeline.model.params, "max_velocity_mps", None) or 5.0  # a family renders up to its own maximum
    for v in (min(0.5, top), pipeline.effect.velocity_mps or 3.0, min(5.0, top)):
        out = pipeline.render(velocity=v).output.samples
        assert abs(out[0]) < 1e-3 and abs(out[-1]) < 1e-3, (v, out[0], out[-1])
