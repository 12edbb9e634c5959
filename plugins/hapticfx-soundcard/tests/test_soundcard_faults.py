"""Faults on a real sound server: it dies, stalls, or its device disappears mid-stream, and comes back.

Each runs an embedding program (hapticfx_soundcard.bench.faultprobe) against its own PulseAudio
instance, so the shared test server is not touched, and checks: a clear
DeviceError within 1 s, play() during the outage raises at once, what was sounding
is counted as lost, another actuator keeps working, close() returns, the program
exits normally (no hang at exit), and PortAudio's diagnostics reach stderr as one
summary line. When the server resumes or is restarted, impacts are heard again.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from soundcard_server import start_soundserver, stop_soundserver

pytestmark = pytest.mark.soundserver
SCRIPT = Path(__file__).resolve().parents[3] / ".ci" / "soundserver.sh"


def run_child(mode, tmp_path, queue=0.0, latency=None):
    runtime = str(tmp_path / "xdg")
    start_soundserver(runtime)
    try:
        pid = (Path(runtime) / "pulse" / "pid").read_text().strip()
        env = {**os.environ, "XDG_RUNTIME_DIR": runtime, "HAPTICFX_XDG": runtime, "HAPTICFX_SOUNDSERVER": str(SCRIPT)}
        done = subprocess.run([sys.executable, "-m", "hapticfx_soundcard.bench.faultprobe", mode, pid, str(queue),
                               *([] if latency is None else [str(latency)])], env=env,
                              capture_output=True, text=True, timeout=60)
    finally:
        stop_soundserver(runtime)
    assert done.returncode == 0, done.stdout + done.stderr
    return dict(line.split(" ", 1) for line in done.stdout.splitlines() if " " in line), done.stderr


def quiet(stderr: str) -> bool:
    """No raw PortAudio/ALSA line; at most one summary of those hidden."""
    lines = stderr.splitlines()
    raw = [x for x in lines if x.startswith(("Expression '", "ALSA lib"))]
    summaries = [x for x in lines if x.startswith("hapticfx-soundcard: hid ")]
    assert not raw and len(summaries) <= 1, stderr
    return True


PORTAUDIO = "sound output 'default' unavailable:"
QUEUE = "the PulseAudio default sink unavailable:"


@pytest.mark.parametrize("mode, queue, output, cause", [
    ("kill", 0.0, PORTAUDIO, "stopped by itself"),
    ("unload", 0.0, PORTAUDIO, "stopped by itself"),
    ("stall", 0.0, PORTAUDIO, "no audio callback"),
    ("kill", 0.1, QUEUE, "closed the connection"),
    ("unload", 0.1, QUEUE, "ended the stream"),
    ("stall", 0.1, QUEUE, "no request for audio"),
])
def test_a_failing_sound_server_gives_a_clear_error_quickly(mode, queue, output, cause, tmp_path):
    seen, stderr = run_child(mode, tmp_path, queue)
    assert seen["detected_s"] != "never"
    assert float(seen["detected_s"]) < 1.0  # the watchdog's 0.5 s, with a margin for a loaded machine
    # PortAudio's report that the stream ended races the 0.5 s watchdog: on a loaded machine the watchdog
    # may tell a dead server first, in its own words
    causes = (cause, "no audio callback") if output == PORTAUDIO else (cause,)
    assert seen["message"].startswith(output) and any(c in seen["message"] for c in causes), seen["message"]
    assert float(seen["play_after_s"].split()[0]) < 0.25  # at once: not after a reconnection's 0.5 s
    assert int(seen["lost"]) == 1  # the tone that was sounding
    assert seen["outages"] == "1"  # one outage, however it was noticed
    assert seen["other_played"] == "1"
    assert float(seen["close_s"]) < 1.5
    assert quiet(stderr)


@pytest.mark.parametrize("queue", [0.0, 0.1])
@pytest.mark.parametrize("mode", ["stall-resume", "restart"])
def test_impacts_are_heard_again_once_the_server_is_back(mode, queue, tmp_path):
    """A PortAudio stream starts with a 0.1 s buffer that may grow to 1 s: the outage's gap does not lengthen
    it. A machine that itself stalls the stream for longer than that away from the outage (seen at load 6-7)
    rightly does, so the buffer is checked where the probe saw no such stall (how often a busy machine starves
    the shipped 'low' buffer is `hapticfx bench output`'s question)."""
    seen, stderr = run_child(mode, tmp_path, queue, latency=0.1 if queue == 0.0 else None)
    assert float(seen["detected_s"]) < 1.0
    assert seen["recovered_s"] != "never"
    assert seen["heard"] == "1"
    if mode == "stall-resume":  # at the stream's usual latency, not late by the 1 s that the stall threw off
        assert float(seen["heard_after_s"]) < 0.5, seen["heard_after_s"]
    if seen["stalls_outside"] == "0":
        assert seen["buffer_changes"] == "0"  # the gap of an outage is not one that a longer buffer would hold
    assert float(seen["close_s"]) < 1.5
    assert quiet(stderr)
