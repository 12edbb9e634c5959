"""An embedding program whose sound server fails mid-stream (run by test_faults.py).

argv: MODE (kill | unload | stall) and the PulseAudio pid. Prints one
``key value`` line per observation; exits 0 when it survived.
"""

import os
import signal
import subprocess
import sys
import time

import numpy as np
from hapticfx.errors import DeviceError
from hapticfx.params import BuildContext
from hapticfx.registry import get_registry
from hapticfx.signal import Signal

from hapticfx_soundcard.actuator import VibroTransducer

mode, server_pid = sys.argv[1], int(sys.argv[2])
rate = 48000
tone = Signal(0.2 * np.sin(2 * np.pi * 100 * np.arange(2 * rate) / rate), rate)

act = VibroTransducer(VibroTransducer.Params(), BuildContext(device="default"))
other = get_registry().create("actuator", "memory")
act.open()
other.open()
act.play(tone)
time.sleep(0.3)
print("playing", flush=True)

t_fault = time.monotonic()
if mode == "kill":
    os.kill(server_pid, signal.SIGKILL)
elif mode == "stall":
    os.kill(server_pid, signal.SIGSTOP)
elif mode == "unload":
    subprocess.run(["pactl", "unload-module", "module-null-sink"], check=True, timeout=5)
else:
    raise SystemExit(f"unknown mode {mode}")

while True:
    try:
        act.check()
    except DeviceError as exc:
        print(f"detected_s {time.monotonic() - t_fault:.3f}", flush=True)
        print(f"message {exc}", flush=True)
        break
    if time.monotonic() - t_fault > 5:
        print("detected_s never", flush=True)
        break
    time.sleep(0.005)

t = time.monotonic()
try:
    act.play(tone)
    print("play_after no error", flush=True)
except DeviceError as exc:
    print(f"play_after_s {time.monotonic() - t:.3f} {exc}", flush=True)

other.play(tone)
print(f"other_played {len(other.played)}", flush=True)

t = time.monotonic()
act.close()
other.close()
print(f"close_s {time.monotonic() - t:.3f}", flush=True)
