"""A program whose sound server fails under a playing actuator: ``python -m hapticfx_soundcard.bench.faultprobe MODE PID [QUEUE [LATENCY]]``.

Run by the fault tests and by ``hapticfx bench output``, each against a PulseAudio
server of its own (PID). MODE is kill | unload | stall (the server stays broken),
or stall-resume (stopped for 1 s, then continued) | restart (killed, then started
again by .ci/soundserver.sh, whose path is in ``HAPTICFX_SOUNDSERVER``). Prints one
``key value`` line per observation; exits 0 when it survived. ``recovered_s`` is
from the server's return (continued, or answering ``pactl info`` again) to the
first impact the actuator takes again; ``outages_after_back`` (restart) counts the outages of the
stream after that (a server just started may stall its first streams), before a click is played once
the server has settled; ``heard`` counts the clicks then recorded from the sink's monitor,
``heard_after_s`` (stall-resume) how long after ``play`` the first began; ``buffer_changes`` how often
the stream's buffer was lengthened, ``stalls_outside`` how many waits between audio callbacks
outlasted the buffer away from the outage (the machine's own); ``outages`` how many outages the
output had when the fault was detected.
QUEUE (seconds, default 0) is the actuator's ``queue`` option: the PulseAudio queue instead of PortAudio.
LATENCY (seconds; default PortAudio's 'low' with the shipped max_latency) starts the PortAudio stream with
that buffer and lets it grow up to 1 s: the tests' choice, a buffer that a loaded machine's own stalls do
not empty, so that a lengthened buffer can only be the outage's.
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
from hapticfx_soundcard.bench.output import LoopbackRecorder, click, onsets

mode, server_pid = sys.argv[1], int(sys.argv[2])
queue = float(sys.argv[3]) if len(sys.argv) > 3 else 0.0
buffer = dict(latency=float(sys.argv[4]), max_latency=1.0) if len(sys.argv) > 4 else {}
rate = 48000
CAPTURE_S = 0.25
tone = Signal(0.2 * np.sin(2 * np.pi * 100 * np.arange(2 * rate) / rate), rate)


def say(key, value):
    print(f"{key} {value}", flush=True)


def wait_until_it_plays(since: float, key: str) -> bool:
    """Wait up to 10 s for the actuator to take impacts again; says ``key`` (seconds since ``since``, or never)."""
    while True:
        try:
            act.check()
            say(key, f"{time.monotonic() - since:.3f}")
            return True
        except DeviceError:
            if time.monotonic() - since > 10:
                say(key, "never")
                return False
            time.sleep(0.005)


act = VibroTransducer(VibroTransducer.Params(queue=queue, **buffer), BuildContext(device="default"))
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
say("outages", act.outages)

other.play(tone)
say("other_played", other.received)

if mode in ("stall-resume", "restart"):
    if mode == "stall-resume":
        time.sleep(max(0.0, t_fault + 1.0 - time.monotonic()))
        os.kill(server_pid, signal.SIGCONT)
        t_back = time.monotonic()
    else:
        server = subprocess.Popen(["bash", os.environ["HAPTICFX_SOUNDSERVER"]], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
        # client.conf (written by the script) says autospawn = no: pactl must not start a server of its own
        quiet = {**os.environ, "PULSE_CLIENTCONFIG": os.path.join(os.environ["XDG_RUNTIME_DIR"], "client.conf")}
        while subprocess.run(["pactl", "info"], capture_output=True, env=quiet).returncode != 0:
            if server.poll() not in (None, 0):
                raise SystemExit("the sound server did not start again")
            time.sleep(0.01)
        t_back = time.monotonic()
    outages = act.outages
    if not wait_until_it_plays(t_back, "recovered_s"):
        raise SystemExit("the actuator took no impact within 10 s of the server's return")
    if mode == "restart":
        # A server just started may stall its first streams for 1-2 s on a loaded machine (seen beside
        # stress-ng --cpu 2): a second outage, which the stream reports and comes back from like the first.
        # The click is played once the server has settled as its script waits for (keep-alive, then 2.5 s)
        # and the stream plays again; how many such outages there were is reported, not hidden.
        server.wait(timeout=30)
        if not wait_until_it_plays(time.monotonic(), "settled_s"):
            raise SystemExit("the actuator took no impact within 10 s of the server settling")
        say("outages_after_back", act.outages - outages)
    # the impact is heard, on the same (or the new) server; through a capture buffer that a loaded machine does
    # not overflow (its times are the capture's clock, which the buffer does not move)
    with LoopbackRecorder(rate, latency=CAPTURE_S) as rec:
        time.sleep(0.2)
        sent = rec.now()
        act.play(Signal(click(rate), rate))
        time.sleep(0.4 + CAPTURE_S)
    x, t = rec.capture.timeline(0)
    heard = onsets(x, t)
    say("heard", len(heard))
    if mode == "stall-resume":  # on a server just started, the capture's clock is not yet to be trusted
        say("heard_after_s", f"{heard[0] - sent:.3f}" if len(heard) else "never")
    say("buffer_changes", len(act.buffer_changes))
    # waits between audio callbacks longer than the buffer that lie wholly outside the outage: the machine's
    # own stalls, which a longer buffer rightly answers
    say("stalls_outside", sum(1 for end, gap in act.late_callbacks if end < t_fault or end - gap > t_back))

t = time.monotonic()
act.close()
other.close()
say("close_s", f"{time.monotonic() - t:.3f}")
