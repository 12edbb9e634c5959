"""Faults on a real sound server: it dies, stalls, or its device disappears mid-stream.

Each runs an embedding program (soundcard_fault_child.py) against its own PulseAudio
instance, so the shared test server is not touched, and checks: a clear
DeviceError within 1 s, play() after it raises at once, another actuator
keeps working, close() returns, and the program exits normally (no hang at exit).
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from soundcard_server import start_soundserver, stop_soundserver

pytestmark = pytest.mark.soundserver
CHILD = Path(__file__).with_name("soundcard_fault_child.py")


@pytest.mark.parametrize("mode, cause", [
    ("kill", "stopped by itself"),
    ("unload", "stopped by itself"),
    ("stall", "no audio callback"),
])
def test_a_failing_sound_server_gives_a_clear_error_quickly(mode, cause, tmp_path):
    runtime = str(tmp_path / "xdg")
    start_soundserver(runtime)
    try:
        pid = (Path(runtime) / "pulse" / "pid").read_text().strip()
        env = {**os.environ, "XDG_RUNTIME_DIR": runtime}
        done = subprocess.run([sys.executable, str(CHILD), mode, pid], env=env, capture_output=True,
                              text=True, timeout=30)
    finally:
        stop_soundserver(runtime)
    seen = dict(line.split(" ", 1) for line in done.stdout.splitlines() if " " in line)
    assert done.returncode == 0, done.stdout + done.stderr
    assert seen["detected_s"] != "never"
    assert float(seen["detected_s"]) < 1.0
    assert seen["message"].startswith("sound output 'default' failed:") and cause in seen["message"]
    assert float(seen["play_after_s"].split()[0]) < 0.05
    assert seen["other_played"] == "1"
    assert float(seen["close_s"]) < 1.5
