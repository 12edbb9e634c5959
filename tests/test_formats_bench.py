"""The round-trip measures of `hapticfx bench formats`, checked on cases whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.bench.formats import compare, measure, print_tables
from hapticfx.processing import perceptual

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


def test_the_perceptual_columns_are_the_projects_measures_and_never_complex():
    x = decay()
    same = compare(x, x.copy(), RATE)
    assert (same["st_sim"], same["spqi"]) == (1.0, 1.0)
    quiet = compare(x, 0.5 * x, RATE)
    assert quiet["spqi"] < 0.5 * quiet["st_sim"]  # SPQI: a level change is a large loss; ST-SIM mostly keeps the shape
    assert (quiet["st_sim"], quiet["spqi"]) == pytest.approx(tuple(perceptual.scores(0.5 * x, x[None], rate_hz=RATE).values()))
    short = decay(n=400)  # 50 ms: shorter than one 512-sample block at 2.8 kHz; padded, not refused
    assert compare(short, short.copy(), RATE)["spqi"] == 1.0
    noise = np.random.default_rng(1).standard_normal(2800)
    shifted = compare(noise, np.roll(noise, 5), 2800.0)  # vibromaf 0.0.8 returns a complex ST-SIM for this pair
    assert isinstance(shifted["st_sim"], float) and 0 <= shifted["st_sim"] <= 1 and 0 <= shifted["spqi"] <= 1


def _has(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None


def test_the_bench_measures_one_effect_through_every_format(tmp_path):
    from pathlib import Path

    effect = Path(__file__).resolve().parents[1] / "effects" / "families" / "bat_ball.yaml"
    rows = measure([effect], repeats=1)
    waveform = {"android-ogg"} if _has("soundfile") else set()
    assert {r.format for r in rows} - {"android-ogg"} == {"haptic", "haptic-notr", "ahap", "android", "hjif"}
    assert waveform <= {r.format for r in rows}
    assert all(r.bytes > 100 and r.export_ms > 0 and np.isfinite(r.envelope) for r in rows)
    assert all(0 <= r.st_sim and 0 <= r.spqi <= 1 for r in rows)  # every round trip scored, none blank
    text = print_tables(rows)
    assert "bat_ball" in text and "medians over the effects" in text
