"""The Godot 3 example (examples/godot/), run headless against `hapticfx serve` with a WAV output.

Godot's own physics finds the head contacts; its scripts send them as OSC. The drop heights are the
example's (Room.gd): 0.45, 0.75, 1.05 and 1.35 m from an object's underside to the top of the head, so each
object arrives at the free-fall speed sqrt(2 g h): 2.97, 3.84, 4.54 and 5.15 m/s.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hapticfx.actuators.files import read_wav

ROOT = Path(__file__).resolve().parents[1]
PROJECT = ROOT / "examples" / "godot"
GODOT = shutil.which("godot3-server")
DROPS_M = {"plastic-frame": 0.45, "concrete-brick": 0.75, "wood-beam": 1.05, "steel-plate": 1.35}
G = 9.80665

pytestmark = [
    pytest.mark.engines,
    pytest.mark.skipif(GODOT is None, reason="godot3-server is not installed (scripts/install.sh --test installs it)"),
]


def test_drop_heights_in_the_test_are_the_examples():
    room = (PROJECT / "Room.gd").read_text()
    for obj, h in DROPS_M.items():
        assert re.search(rf'\["{obj}", [\d.]+, Vector3\([^)]*\), {h}, ', room), obj


def test_godot_room_sends_each_head_contact_at_its_free_fall_speed(tmp_path):
    wav, log = tmp_path / "room.wav", tmp_path / "impacts.jsonl"
    serve = subprocess.Popen(
        [sys.executable, "-m", "hapticfx", "serve", str(ROOT / "scenes" / "earthquake_room.yaml"), "--port", "0",
         "--device", f"wav:{wav}", "--log", str(log)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = serve.stdout.readline()
        assert line.startswith("listening on 127.0.0.1:"), line + serve.stderr.read()
        port = line.split()[2].rsplit(":", 1)[1]
        # --fixed-fps: one physics step per frame, as fast as the machine goes (no waiting on the wall clock)
        godot = subprocess.run([GODOT, "--path", str(PROJECT), "--fixed-fps", "480"], capture_output=True, text=True,
                               timeout=120, env={**os.environ, "HAPTICFX_PORT": port, "HOME": str(tmp_path)})
    finally:
        if godot_done := serve.poll() is None:
            import time

            time.sleep(0.5)  # the last datagram reaches the server before it is told to stop
            serve.send_signal(signal.SIGTERM)
        out, err = serve.communicate(timeout=60)
    assert godot_done and serve.returncode == 0, err
    assert godot.returncode == 0, godot.stdout + godot.stderr
    sent = [m.groups() for m in re.finditer(r"hapticfx: impact (\S+) ([\d.]+) m/s at ([\d.]+) s", godot.stdout)]
    final = json.loads(out.strip().splitlines()[-1])
    assert final["bridge"]["accepted"] == len(sent) == 4 and final["bridge"]["dropped_total"] == 0
    assert final["engine"]["rendered"] == 4 and final["engine"]["failed"] == 0

    played = [json.loads(x) for x in log.read_text().splitlines()]
    assert [p["object"] for p in played] == [s[0] for s in sent] == list(DROPS_M)  # lowest shelf first
    for p, (obj, speed, at) in zip(played, sent):
        free_fall = math.sqrt(2 * G * DROPS_M[obj])
        assert p["velocity"] == pytest.approx(free_fall, rel=0.10), (obj, p["velocity"], free_fall)
        assert p["velocity"] == pytest.approx(float(speed), abs=1e-4)  # float32 on the wire
        assert p["at"] == pytest.approx(float(at), abs=1e-3)           # Godot's clock, sent as a double
        # the objects land flat on the top of the head: the crown, normal up (head frame: z up)
        assert p["point"][2] == pytest.approx(0.13, abs=0.005) and p["normal"][2] > 0.99

    # the WAV is the session on Godot's timeline: each impact starts at its time after the first, to 1 ms
    rate, samples = read_wav(wav)
    assert samples.shape[0] == 1 and np.all(np.isfinite(samples))
    x = np.abs(samples[0])
    assert 0 < x.max() <= 1.0
    for p in played:
        start = int(round((p["at"] - played[0]["at"]) * rate))
        assert x[max(0, start - int(0.2 * rate)):max(0, start - int(0.001 * rate))].max(initial=0) < 1e-6, p["object"]
        assert x[start:start + int(0.001 * rate) + 1].max() > 1e-6, p["object"]
