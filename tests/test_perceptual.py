"""ST-SIM and SPQI: known cases, and agreement with the authors' implementation (vibromaf) where it is right."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.processing import perceptual as P


def _impact(n=500, rate=1000.0):
    t = np.arange(n) / rate
    return 2.0 * np.sin(2 * np.pi * 118 * t) * np.exp(-18 * t) + 0.8 * np.sin(2 * np.pi * 395 * t) * np.exp(-40 * t)


def test_identical_signals_score_one_and_scores_fall_with_noise():
    x = P.prepare(_impact(), rate_hz=1000.0)
    assert P.st_sim(x, x) == 1.0 and P.spqi(x, x) == 1.0
    assert P.scores(_impact(), _impact()[None], rate_hz=1000.0) == {"stsim": 1.0, "spqi": 1.0}
    rng = np.random.default_rng(0)
    last = {"stsim": 1.0, "spqi": 1.0}
    for snr_db in (30, 10, 0):
        n = rng.standard_normal(len(x))
        n *= np.sqrt(np.mean(x**2) / np.mean(n**2) / 10 ** (snr_db / 10))
        now = {"stsim": P.st_sim(x + n, x), "spqi": P.spqi(x + n, x)}
        assert all(0 <= v < last[k] + 0.01 for k, v in now.items()) and now["spqi"] < last["spqi"]
        last = now
    assert last["stsim"] < 0.8 and last["spqi"] < 0.2


def test_resampled_to_2800_hz_in_whole_blocks_without_new_content():
    x = _impact()
    p = P.prepare(x, rate_hz=1000.0)
    assert len(p) == 3 * P.BLOCK and np.all(p[1400:] == 0)
    spectrum = np.abs(np.fft.rfft(p[:1400]))
    f = np.fft.rfftfreq(1400, 1 / 2800)
    assert np.sum(spectrum[f > 600] ** 2) < 1e-3 * np.sum(spectrum**2)  # no images above the 1 kHz signal's Nyquist
    assert np.isclose(np.abs(p).max(), np.abs(x).max() * P.G, rtol=0.05)


def test_anti_correlated_signal_scores_zero_not_a_complex_number():
    t = np.arange(1536) / 1000.0
    x = np.sin(2 * np.pi * 100 * t) * np.exp(-3 * t)
    shifted = np.roll(x, 5)  # half a period: every block anti-correlated
    score = P.st_sim(shifted, x)
    assert isinstance(score, float) and score == 0.0


def test_arrays_of_signals_score_each_pair_as_one_pair_does():
    rng = np.random.default_rng(3)
    x = np.array([P.prepare(_impact() * (1 + 0.3 * k) + 0.2 * rng.standard_normal(500), rate_hz=1000.0)
                  for k in range(4)])
    x[2], x[3] = x[1], 0.0  # an identical pair, and silence
    for measure in (P.st_sim, P.spqi):
        one_by_one = np.array([[measure(a, b) for b in x] for a in x])
        assert all(isinstance(v, float) for v in one_by_one.ravel())
        assert one_by_one[1, 2] == one_by_one[3, 3] == 1.0
        assert np.all(np.isfinite(one_by_one)) and np.all((one_by_one >= 0) & (one_by_one <= 1))
        assert np.array_equal(measure(x[:, None], x[None, :]), one_by_one)  # bit for bit, not just close
        assert np.array_equal(measure(x[0], x), one_by_one[0])  # one signal against each of several


def test_threshold_lies_on_the_bins_own_frequencies():
    t = P.threshold_db(2800.0)
    k250 = int(round(250 / (2800 / (2 * P.BLOCK))))
    assert np.argmin(t) in range(k250 - 1, k250 + 2) and np.isclose(t.min(), -77, atol=0.1)


vibromaf = pytest.importorskip("vibromaf", reason="the authors' implementation (pip install vibromaf)")


def _vibromaf_at(rate_hz):
    from vibromaf.metrics.spqi import SPQI
    from vibromaf.metrics.stsim import STSIM
    from vibromaf.signal.perception import PerceptualThreshold
    from vibromaf.signal.transform import PerceptualSpectrumBuilder

    builder = PerceptualSpectrumBuilder(perceptual_threshold=PerceptualThreshold(rate_hz))
    st, sp = STSIM(2 / 3), SPQI(0.3, -2.0)
    object.__setattr__(st, "perceptual_spectrum_builder", builder)
    object.__setattr__(sp, "perceptual_spectrum_builder", builder)
    return st, sp


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_agrees_with_vibromaf_where_vibromaf_is_right():
    st, sp = _vibromaf_at(2800)
    ref = P.prepare(_impact(), rate_hz=1000.0)
    rng = np.random.default_rng(3)
    cases = [P.prepare(0.7 * _impact(), rate_hz=1000.0), np.roll(ref, 5), ref + 0.3 * rng.standard_normal(len(ref)),
             P.prepare(_impact() * np.exp(-np.arange(500) / 80), rate_hz=1000.0)]
    for dist in cases:
        assert np.isclose(P.st_sim(dist, ref), st.calculate(dist, ref), rtol=1e-9)
        assert np.isclose(P.spqi(dist, ref), sp.calculate(dist, ref), rtol=1e-9)
    # its default grid is 8 kHz whatever the signal: the same numbers when we lay ours there
    from vibromaf.metrics.spqi import spqi
    from vibromaf.metrics.stsim import st_sim

    assert np.isclose(P.st_sim(cases[0], ref, rate_hz=8000.0), st_sim(cases[0], ref), rtol=1e-9)
    assert np.isclose(P.spqi(cases[0], ref, rate_hz=8000.0), spqi(cases[0], ref), rtol=1e-9)
    # where it is wrong: a negative temporal similarity to the power 2/3 comes out complex
    t = np.arange(1536) / 1000.0
    x = np.sin(2 * np.pi * 100 * t) * np.exp(-3 * t)
    assert isinstance(st_sim(np.roll(x, 5), x), complex)
