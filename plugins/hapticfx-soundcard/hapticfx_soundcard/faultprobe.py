"""An embedding program whose sound server fails mid-stream (run by test_soundcard_faults.py).

argv: MODE and the PulseAudio pid. MODE is kill | unload | stall (the server
stays broken), or stall-resume (stopped for 1 s, then continued) | restart
(killed, then started again by .ci/soundserver.sh). Prints one ``key value``
line per observation; exits 0 when it survived.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from hapticfx.errors import DeviceError
from hapticfx.params import BuildContext
from hapticfx.registry import get_registry
from hapticfx.signal import Signal

from hapticfx_soundcard.actuator import VibroTransducer
from hapticfx_soundcard.bench import LoopbackRecorder, click, onsets

SCRIPT = Path(__file__).resolve().parents[3] / ".ci" / "soundserver.sh"
mode, server_pid = sys.argv[1], int(sys.argv[2])
rate = 48000
tone = Signal(0.2 * np.sin(2 * np.pi * 100 * np.arange(2 * rate) / rate), rate)


def say(key, value):
    print(f"{key} {value}", flush=True)


act = VibroTransducer(VibroTransducer.Params(), BuildContext(device="default"))
other = get_registry().create("actuator", "memory")
act.open()
other.open()
act.play(tone)
time.sleep(0.3)
say("playing", "yes")

t_fault = time.monotonic()
if mode in ("kill", "restart"):
    os.kill(server_pid, signal.SIGKILL)
elif mode in ("stall", "stall-resume"):
    os.kill(server_pid, signal.SIGSTOP)
elif mode == "unload":
    subprocess.run(["pactl", "unload-module", "module-null-sink"], check=True, timeout=5)
else:
    raise SystemExit(f"unknown mode {mode}")

while True:
    try:
        act.check()
    except DeviceError as exc:
        say("detected_s", f"{time.monotonic() - t_fault:.3f}")
        say("message", exc)
        break
    if time.monotonic() - t_fault > 5:
        say("detected_s", "never")
        break
    time.sleep(0.005)

t = time.monotonic()
try:
    act.play(tone)
    say("play_after", "no error")
except DeviceError as exc:
    say("play_after_s", f"{time.monotonic() - t:.3f} {exc}")
say("lost", act.losses().get("outage", 0))

other.play(tone)
say("other_played", other.received)

if mode in ("stall-resume", "restart"):
    if mode == "stall-resume":
        time.sleep(max(0.0, t_fault + 1.0 - time.monotonic()))
        os.kill(server_pid, signal.SIGCONT)
    else:
        subprocess.run(["bash", str(SCRIPT)], check=True, capture_output=True, timeout=30)
    t_back = time.monotonic()
    while True:
        try:
            act.check()
            say("recovered_s", f"{time.monotonic() - t_back:.3f}")
            break
        except DeviceError:
            if time.monotonic() - t_back > 10:
                say("recovered_s", "never")
                break
            time.sleep(0.005)
    with LoopbackRecorder(rate) as rec:  # the impact is heard, on the same (or the new) server
        time.sleep(0.2)
        act.play(Signal(click(rate), rate))
        time.sleep(0.4)
    x, t = rec.capture.timeline(0)
    say("heard", len(onsets(x, t)))

t = time.monotonic()
act.close()
other.close()
say("close_s", f"{time.monotonic() - t:.3f}")
