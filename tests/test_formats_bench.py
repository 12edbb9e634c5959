"""The round-trip measures of `hapticfx bench formats`, checked on cases whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.bench import vibrotactile
from hapticfx.bench.formats import compare, measure, print_tables

RATE = 8000.0


def decay(f=120.0, n=4000, rate=RATE):
    t = np.arange(n) / rate
    return np.exp(-t / 0.05) * np.sin(2 * np.pi * f * t)


def test_a_signal_against_itself_is_perfect():
    x = decay()
    m = compare(x, x.copy(), RATE)
    assert m["envelope"] == 0 and m["dominant"] == 0 and m["centroid"] == 0 and m["lsd_db"] == 0
    assert m["dominant_hz"] == pytest.approx(120, abs=1)


def test_the_measures_see_a_wrong_frequency_and_a_wrong_level():
    x = decay()
    wrong = compare(x, decay(f=60.0), RATE)
    assert wrong["dominant"] == pytest.approx(0.5, abs=0.02) and wrong["envelope"] < 0.05 and wrong["lsd_db"] > 5
    quiet = compare(x, 0.5 * x, RATE)  # half the envelope: RMS of e/2 over a 50 ms decay held for 0.5 s
    assert quiet["envelope"] == pytest.approx(0.5 * np.sqrt(np.mean(np.exp(-np.arange(500) / 25.0))), rel=0.15)
    assert quiet["dominant"] == 0


vibromaf = pytest.importorskip("vibromaf", reason="the perceptual extra (vibromaf) is not installed")


def test_vibromaf_on_known_cases():
    x = decay()
    assert vibrotactile.scores(x, x, RATE) == (1.0, 1.0)
    st, sp = vibrotactile.scores(x, 0.5 * x, RATE)
    assert sp < 0.1  # SPQI: a level change is a large loss
    short = decay(n=400)  # 50 ms: shorter than vibromaf's 512-sample block at 2.8 kHz; padded, not refused
    assert vibrotactile.scores(short, short, RATE) == (1.0, 1.0)


def test_a_complex_st_sim_is_reported_as_nan():
    noise = np.random.default_rng(1).standard_normal(2800)
    st, sp = vibrotactile.scores(noise, np.roll(noise, 5), 2800.0)  # vibromaf 0.0.8 returns a complex ST-SIM here
    assert np.isnan(st) and 0 <= sp <= 1


def _has(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None


def test_the_bench_measures_one_effect_through_every_format(tmp_path):
    from pathlib import Path

    effect = Path(__file__).resolve().parents[1] / "effects" / "families" / "bat_ball.yaml"
    rows = measure([effect], repeats=1)
    waveform = {"android-ogg"} if vibrotactile.available() and _has("soundfile") else set()
    assert {r.format for r in rows} - {"android-ogg"} == {"haptic", "haptic-notr", "ahap", "android", "hjif"}
    assert waveform <= {r.format for r in rows}
    assert all(r.bytes > 100 and r.export_ms > 0 and np.isfinite(r.envelope) for r in rows)
    text = print_tables(rows)
    assert "bat_ball" in text and "medians over the effects" in text
