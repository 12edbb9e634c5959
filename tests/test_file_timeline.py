"""File outputs hold a session on its own timeline: each impact at its time, summed, limited in the file's time.

Sessions go over real UDP to `hapticfx serve` (a subprocess) or to the engine's OSC bridge in this process;
what is checked is read back from the WAV and CSV files.
"""

from __future__ import annotations

import csv
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from pythonosc.osc_bundle_builder import OscBundleBuilder
from pythonosc.osc_message_builder import OscMessageBuilder

from hapticfx.actuators.files import read_wav
from hapticfx.actuators.timeline import Timeline
from hapticfx.engine import Engine
from hapticfx.interfaces import SafetyLimits
from hapticfx.osc import OscBridge

SCENE = """
name: session
actuators:
  helmet: {{type: {kind}, path: {path}, rate_hz: {rate}, {extra}{limits}}}
effects:
  concrete-brick:
    actuator: helmet
    inline: {{name: brick, object: concrete-brick, model: {{type: kinetic-energy}}, actuator: {{type: memory}}}}
  steel-plate:
    actuator: helmet
    inline: {{name: steel, object: steel-plate, model: {{type: kinetic-energy}}, actuator: {{type: memory}}}}
events:
  osc: {{host: 127.0.0.1, port: 0, rate_hz: 0}}
engine: {{queue_size: 100000}}
"""


def write_scene(tmp_path, *, kind="wav", rate=48000, extra="format: float32", limits="", name="helmet"):
    path = tmp_path / f"{name}.{kind}"
    scene = tmp_path / f"{name}.yaml"
    scene.write_text(SCENE.format(kind=kind, path=path, rate=rate, extra=extra,
                                  limits=f", limits: {limits}" if limits else ""))
    return scene, path


def message(obj: str, velocity: float, at: float | None = None):
    b = OscMessageBuilder("/hapticfx/impact")
    b.add_arg(obj)
    b.add_arg(velocity, "f")
    if at is not None:
        b.add_arg(-1, "i")
        b.add_arg(at, "d")
    return b.build()


def impact(obj: str, velocity: float, at: float | None = None) -> bytes:
    return message(obj, velocity, at).dgram


def bundled(obj: str, velocity: float, timetag: float) -> bytes:
    """One impact in an OSC bundle whose timetag (Unix seconds) is its engine time."""
    b = OscBundleBuilder(timetag)
    b.add_content(message(obj, velocity))
    return b.build().dgram


def onsets(x: np.ndarray, rate: float, *, quiet_s: float = 0.1) -> np.ndarray:
    """Sample indices where the signal rises above 2% of its peak after at least ``quiet_s`` below it."""
    loud = np.flatnonzero(np.abs(x) > 0.02 * np.max(np.abs(x)))
    starts = np.concatenate([[0], np.flatnonzero(np.diff(loud) > quiet_s * rate) + 1])
    return loud[starts]


def window_rms(x: np.ndarray, n: int) -> float:
    """The largest RMS over any ``n`` consecutive samples (float64, the file's own samples)."""
    c = np.concatenate([[0.0], np.cumsum(x.astype(np.float64) ** 2)])
    return float(np.sqrt(np.max(c[n:] - c[:-n]) / n)) if x.size >= n else float(np.sqrt(c[-1] / n))


@pytest.mark.parametrize("carrier", ["at", "bundle timetag"])
def test_serve_writes_a_session_whose_onsets_are_the_sent_engine_times(tmp_path, carrier):
    """Issue 28: impacts sent to `serve` with their engine time (the `at` argument, or a bundle's timetag)
    give a WAV whose onsets match those times within 1 ms, however they were spaced in arrival (here: sent
    back to back)."""
    scene, wav = write_scene(tmp_path)
    proc = subprocess.Popen([sys.executable, "-m", "hapticfx", "serve", str(scene), "--stats-every", "0.2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert line.startswith("listening on 127.0.0.1:"), line + proc.stderr.read()
    port = int(line.split()[2].rsplit(":", 1)[1])
    sent = [1000.0, 1000.25, 1000.6125, 1001.3, 1002.0417, 1002.5]
    if carrier != "at":
        sent = [1.7e9 + t for t in sent]  # a timetag is wall-clock time
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
        for at in sent:
            data = impact("concrete-brick", 3.8, at) if carrier == "at" else bundled("concrete-brick", 3.8, at)
            client.sendto(data, ("127.0.0.1", port))
    deadline = time.monotonic() + 30
    while '"rendered": 6' not in line and time.monotonic() < deadline:
        line = proc.stdout.readline()
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    rate, data = read_wav(wav)
    found = onsets(data[0], rate)
    assert found.size == len(sent)
    np.testing.assert_allclose(found / rate - found[0] / rate, np.array(sent) - sent[0], atol=1e-3)
    assert data.shape[1] / rate == pytest.approx(sent[-1] - sent[0], abs=0.5)  # the session's span, no more


def test_without_a_time_each_impact_lies_at_its_arrival(tmp_path):
    """Onset gaps equal the gaps of the engine's recorded arrival times within 1 ms (both are measured on
    this machine, so a busy machine moves both alike)."""
    scene, wav = write_scene(tmp_path, rate=8000, extra="format: pcm24")
    with Engine(scene) as engine:
        bridge = OscBridge(engine.submit, engine.objects, port=0, rate_hz=0)
        with bridge, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
            for pause in (0.0, 0.2, 0.35, 0.15, 0.5):
                time.sleep(pause)
                client.sendto(impact("concrete-brick", 4.0), bridge.address)
            deadline = time.monotonic() + 30
            while engine.stats()["rendered"] < 5 and time.monotonic() < deadline:
                time.sleep(0.01)
        received = np.array([p.received for p in engine.played()])
    rate, data = read_wav(wav)
    found = onsets(data[0], rate)
    assert found.size == 5
    np.testing.assert_allclose(np.diff(found) / rate, np.diff(received), atol=1e-3)


@pytest.mark.parametrize("limits, peak, rms", [("{peak: 0.3, rms: 0.2}", 0.3, 0.2), ("", 1.0, 0.7)])
def test_a_flood_of_overlapping_impacts_holds_the_limits_in_the_files_time(tmp_path, limits, peak, rms):
    """300 impacts 2 ms apart in engine time, as the safety probe sent them: summed in the file, which holds
    peak and 50 ms RMS sample for sample (before: RMS 0.7367-0.7854 against 0.7) and lasts as long as the
    session, not the sum of the impacts."""
    scene, wav = write_scene(tmp_path, limits=limits)
    with Engine(scene) as engine:
        for k in range(300):
            engine.impact(("concrete-brick", "steel-plate")[k % 2], 5.0, at=50.0 + 0.002 * k)
        stats = engine.close(timeout=300)  # a busy machine renders slowly: wait, never cancel
    assert stats["rendered"] == 300 and "losses" not in stats["outputs"]["actuators.helmet"]
    rate, data = read_wav(wav)
    x = data[0]
    assert np.max(np.abs(x)) <= peak * (1 + 1e-6)
    assert window_rms(x, int(round(0.05 * rate))) <= rms * (1 + 1e-6)
    assert window_rms(x, int(round(0.05 * rate))) > 0.5 * rms  # the flood does reach the limit
    longest = max(p.duration_s for p in engine.played())
    assert x.size / rate == pytest.approx(0.598 + longest, abs=1e-3)  # back to back it was 300 x longest


def test_a_files_limiter_acting_on_the_sum_is_in_stats(tmp_path):
    """Impacts that each keep under the limit and sum over it in the file: the file's limiter held, and stats()
    said no limit acted (the file outputs had no limiter_report)."""
    from pathlib import Path

    scene = Path(__file__).resolve().parents[1] / "scenes" / "earthquake_room.yaml"
    with Engine(scene, device=f"wav:{tmp_path / 'x.wav'}") as engine:
        for _ in range(30):
            engine.impact("steel-plate", 5.0, at=1.0)
        stats = engine.close(timeout=300)
    assert not any(p.limited for p in engine.played())  # no impact was limited on its own
    assert any(a.startswith("peak 1 set by actuator") for a in stats["outputs"]["actuators.helmet"]["limits_acted"])


def test_the_files_of_one_session_line_up(tmp_path):
    """Two outputs, two files: both start at the session's first impact, so each impact lies at its time."""
    scene = tmp_path / "two.yaml"
    scene.write_text(f"""
name: two
effects:
  concrete-brick:
    inline: {{name: brick, object: concrete-brick, model: {{type: kinetic-energy}},
             actuator: {{type: wav, path: {tmp_path / 'brick.wav'}, rate_hz: 8000}}}}
  steel-plate:
    inline: {{name: steel, object: steel-plate, model: {{type: kinetic-energy}},
             actuator: {{type: wav, path: {tmp_path / 'steel.wav'}, rate_hz: 8000}}}}
""")
    with Engine(scene) as engine:
        engine.impact("concrete-brick", 4.0, at=20.0)
        engine.impact("steel-plate", 4.0, at=20.75)
        engine.impact("concrete-brick", 4.0, at=21.5)
        assert len(engine._outputs) == 2
    (rate, brick), (_, steel) = read_wav(tmp_path / "brick.wav"), read_wav(tmp_path / "steel.wav")
    np.testing.assert_allclose(onsets(brick[0], rate) / rate, [0.0, 1.5], atol=1e-3)
    np.testing.assert_allclose(onsets(steel[0], rate) / rate, [0.75], atol=1e-3)


def test_a_csv_session_is_placed_and_limited_the_same_way(tmp_path):
    scene, path = write_scene(tmp_path, kind="csv", rate=2000, extra="max_mib: 8", limits="{peak: 0.3, rms: 0.2}")
    with Engine(scene) as engine:
        for k, at in enumerate((3.0, 3.5, 3.5, 4.25)):  # two at once: summed, then limited
            engine.impact(("concrete-brick", "steel-plate")[k % 2], 4.0, at=at)
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t_s", "out"]
    t, x = np.array(rows[1:], dtype=float).T
    np.testing.assert_allclose(np.diff(t), 1 / 2000, rtol=1e-6)
    assert np.max(np.abs(x)) <= 0.3 * (1 + 1e-6) and window_rms(x, 100) <= 0.2 * (1 + 1e-6)
    found = onsets(x, 2000)
    np.testing.assert_allclose(t[found] - t[found[0]], [0.0, 0.5, 1.25], atol=1e-3)


def test_the_file_bound_stops_writing_says_so_once_and_leaves_a_valid_file(tmp_path, caplog):
    scene, wav = write_scene(tmp_path, rate=8000, extra="format: pcm16, max_mib: 0.05")  # 52,428 bytes: 3.3 s
    with caplog.at_level("WARNING", logger="hapticfx.actuators.timeline"):
        with Engine(scene) as engine:
            for k in range(10):
                engine.impact("concrete-brick", 4.0, at=k * 1.0)
            stats = engine.close(timeout=300)  # a busy machine renders slowly: wait, never cancel
    header = 74  # RIFF (12), fmt (24), LIST/INFO/ISFT (30) and data (8) chunk headers
    frames = (int(0.05 * 2**20) - header) // 2
    length = engine.played()[0].duration_s * 8000
    cut = sum(k * 8000 + length > frames for k in range(10))
    assert cut >= 6 and stats["outputs"]["actuators.helmet"]["losses"] == {"cut_at_file_bound": cut}
    bound = [r.getMessage() for r in caplog.records]
    assert len(bound) == 1 and "reached its bound (0.05 MiB, 3.3 s at 8000 Hz)" in bound[0]
    assert wav.stat().st_size == header + 2 * frames <= 0.05 * 2**20
    rate, data = read_wav(wav)
    assert data.shape[1] == frames and onsets(data[0], rate).size == 4


def test_one_impact_past_the_bound_does_not_end_the_recording(tmp_path):
    """A sender's clock that jumps once (1e6 s) lost that impact; it padded the file out to its bound, and every
    later impact, at its own time, was cut."""
    scene, wav = write_scene(tmp_path, rate=8000, extra="format: pcm16, max_mib: 0.05")  # 3.3 s
    with Engine(scene) as engine:
        for at in (0.0, 1e6, 1.0, 2.0):
            engine.impact("concrete-brick", 4.0, at=at)
        stats = engine.close(timeout=300)
    assert stats["outputs"]["actuators.helmet"]["losses"] == {"cut_at_file_bound": 1}
    rate, data = read_wav(wav)
    assert onsets(data[0], rate).size == 3 and data.shape[1] < 3.3 * 8000


def test_play_from_the_cli_puts_its_one_impact_at_0(tmp_path):
    """`play --device wav:` writes what `render` renders, sample for sample: the impact at 0, nothing after."""
    effect = "effects/falling_brick_kinetic.yaml"
    played, rendered = tmp_path / "played.wav", tmp_path / "rendered.wav"
    for args in (["play", effect, "--device", f"wav:{played}"], ["render", effect, "--out", str(rendered)]):
        r = subprocess.run([sys.executable, "-m", "hapticfx", *args], capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
    (rate, a), (rate_b, b) = read_wav(played), read_wav(rendered)
    assert rate == rate_b and a.shape == b.shape and np.max(np.abs(a)) > 0.01
    np.testing.assert_allclose(a, b, atol=2 / 8388607)


def test_csv_device_stands_in_for_the_effects_actuator(tmp_path):
    out = tmp_path / "one.csv"
    r = subprocess.run([sys.executable, "-m", "hapticfx", "play", "effects/falling_brick_kinetic.yaml", "--device",
                        f"csv:{out}"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    with open(out, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t_s", "out"] and float(rows[1][0]) == 0.0
    t, x = np.array(rows[1:], dtype=float).T
    rate = 1 / (t[1] - t[0])
    assert np.max(np.abs(x)) > 0.01 and onsets(x, rate)[0] < 0.001 * rate  # the one impact at 0


def test_timeline_moves_an_impact_older_than_what_is_written_and_counts_it(tmp_path):
    written = []

    class Sink:
        frame_bytes, max_frames, bytes = 8, 10**9, 0

        def write(self, block):
            written.append(block.copy())

        def close(self):
            return None

    t = Timeline(lambda channels: Sink(), 1000.0, SafetyLimits(), max_bytes=10**9, hold_s=0.5)
    t.place(np.full((1, 10), 0.1), 0.0)
    t.place(np.full((1, 10), 0.1), 2.0)  # frames before 1.5 s are now written
    t.place(np.full((1, 10), 0.2), 1.0)  # behind them: starts at the first frame not yet written
    t.close()
    x = np.concatenate(written, axis=1)[0]
    assert t.late == 1 and x.size == 2010
    assert np.all(x[1500:1510] == 0.2) and np.all(x[2000:2010] == 0.1) and np.all(x[10:1500] == 0)


def test_two_effects_with_their_own_wav_actuator_on_one_path_write_one_file_limited_as_one(tmp_path):
    """Each with its own actuator section, both at one path: one output (one file, one limiter on the sum),
    not two files of which the last to close would be all that is left at the path."""
    out = tmp_path / "both.wav"
    own = f"{{type: wav, path: {out}, rate_hz: 8000, format: float32, limits: {{peak: 0.5, rms: 0.3}}}}"
    scene = tmp_path / "two.yaml"
    scene.write_text(f"""
name: two files in one
effects:
  concrete-brick: {{inline: {{name: brick, object: concrete-brick, model: {{type: kinetic-energy}}, actuator: {own}}}}}
  steel-plate: {{inline: {{name: steel, object: steel-plate, model: {{type: kinetic-energy}}, actuator: {own}}}}}
engine: {{queue_size: 1000}}
""")
    with Engine(scene) as engine:
        assert len(engine.stats()["outputs"]) == 1
        for k in range(40):
            engine.impact("concrete-brick" if k % 2 else "steel-plate", 6.0, at=k * 0.002)
        engine.close()
    rate, data = read_wav(out)
    x = data.reshape(-1).astype(np.float64)
    assert rate == 8000 and np.abs(x).max() <= 0.5 + 1e-6
    win = int(0.05 * rate)
    c = np.concatenate([[0.0], np.cumsum(x * x)])
    assert np.sqrt((c[win:] - c[:-win]) / win).max() <= 0.3 * (1 + 1e-6)
    assert x.size >= 0.078 * rate  # both effects' impacts are in it, 2 ms apart over 78 ms
