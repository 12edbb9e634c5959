"""The safety probe's sound-card cases (issue 31): floods through every way of reaching the PulseAudio sink,
what reached it recorded from the sink's monitor (``parec``, a process of its own, so a busy interpreter
loses nothing) and measured against the limit that applies (:mod:`hapticfx.fuzz.probe`).

The monitor of a 16-bit sink rounds to 1/32768: that step is the measurement's tolerance.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np
from hapticfx.engine import Engine
from hapticfx.errors import DeviceError
from hapticfx.params import BuildContext
from hapticfx.fuzz.probe import LOUD, Verdict, measure, refused, write_scene

from ..libpulse import sink_info

RATE = 48000
STEP = 1.0 / 32768  # the monitor's resolution
REPO = Path(__file__).resolve().parents[4]


class Monitor:
    """Records the default sink's monitor into a file with ``parec`` while the block runs; ``samples()``
    after it: (frames, channels) float32."""

    def __init__(self, channels: int = 2):
        if shutil.which("parec") is None:
            raise DeviceError("parec is missing: apt-get install pulseaudio-utils")
        self.sink, self.rate = sink_info(None)
        self.channels = channels
        self._dir = tempfile.TemporaryDirectory()
        self.path = Path(self._dir.name) / "monitor.raw"

    def __enter__(self):
        self._proc = subprocess.Popen(
            ["parec", "-d", f"{self.sink}.monitor", "--raw", "--format=float32le", f"--rate={self.rate}",
             f"--channels={self.channels}", "--latency-msec=250", str(self.path)],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 5
        while not (self.path.exists() and self.path.stat().st_size > 0):
            if self._proc.poll() is not None or time.monotonic() > deadline:
                self._proc.kill()
                raise DeviceError(f"parec recorded nothing from {self.sink}.monitor")
            time.sleep(0.01)
        self._started = time.monotonic()
        return self

    def __exit__(self, *exc):
        time.sleep(0.3)  # what was queued at the server reaches the monitor
        self.wall_s = time.monotonic() - self._started
        self._proc.send_signal(signal.SIGINT)
        try:
            self._proc.wait(5)
        except subprocess.TimeoutExpired:
            self._proc.kill()
        return False

    def samples(self) -> np.ndarray:
        data = np.fromfile(self.path, dtype="<f4")
        data = data[:data.size // self.channels * self.channels].reshape(-1, self.channels)
        self._dir.cleanup()
        # a recording that fell behind loses frames, and a stretch lost moves sound closer together than it
        # played: say how much of the wall time the capture holds (it starts a little before `_started`)
        self.held = f"capture {data.shape[0] / self.rate:.2f} s of {self.wall_s:.2f} s"
        return data


def inline(name: str, obj: str, actuator: str) -> str:
    return f"{{name: {name}, object: {obj}, model: {LOUD}, actuator: {actuator}}}"


def _engine_case(case: str, actuators: str, effects: str, objects: list[str], *, peak: float, rms: float,
                 n: int, every_s: float, engines: int = 1) -> Verdict:
    """Build ``engines`` engines on one scene, flood ``objects`` through them, record what reached the sink."""
    with tempfile.TemporaryDirectory() as tmp:
        scene = write_scene(Path(tmp), actuators, effects)
        with Monitor() as monitor:
            built = [Engine(scene) for _ in range(engines)]
            try:
                for k in range(n):
                    built[k % engines].impact(objects[k % len(objects)], 6.0)
                    time.sleep(every_s)
                deadline = time.monotonic() + 30
                while any(e.stats()["pending"] for e in built) and time.monotonic() < deadline:
                    time.sleep(0.01)
                late = sum(o.get("losses", {}).get("late", 0) for e in built for o in e.stats()["outputs"].values())
                underflows = sum(a.underflows for e in built for o in e._outputs.values() for a in o.actuators)
            finally:
                stats = [e.close() for e in built]
    outputs = len(stats[0]["outputs"])
    x = monitor.samples()
    note = f"{outputs} output(s) in stats(); {late} late writes; {underflows} underflows; {monitor.held}"
    return measure(case, x, RATE, peak=peak, rms=rms, tolerance=STEP, note=note)


HELMET = "  helmet: {{type: vibro-transducer, device: {device}, gain: 1.0{extra}}}"
LIMITED = ", limits: {peak: 0.3, rms: 0.2}"


def queued_flood(*, limited: bool = True, n: int = 300) -> Verdict:
    """Case 1: 300 impacts 2 ms apart through the default sound-card mode (the queue at the server)."""
    case = "queued flood, 300 impacts 2 ms apart" + ("" if limited else ", hard limits")
    return _engine_case(case, HELMET.format(device="default", extra=LIMITED if limited else ""),
                        "  brick: {actuator: helmet, inline: " + inline("b", "concrete-brick", "{type: memory}") + "}",
                        ["brick"], peak=0.3 if limited else 1.0, rms=0.2 if limited else 0.7, n=n, every_s=0.002)


def portaudio_flood(n: int = 300) -> Verdict:
    """Held before: the same flood through a PortAudio stream (`queue: 0`)."""
    return _engine_case("PortAudio (queue: 0) flood, 300 impacts 2 ms apart",
                        HELMET.format(device="default", extra=LIMITED + ", queue: 0"),
                        "  brick: {actuator: helmet, inline: " + inline("b", "concrete-brick", "{type: memory}") + "}",
                        ["brick"], peak=0.3, rms=0.2, n=n, every_s=0.002)


def twice(case: str, first: str, second: str, *, n: int = 200) -> Verdict:
    """Case 2: one physical output reached under two names (two scene actuators, or a scene actuator twice)."""
    actuators = "\n".join([HELMET.format(device=first, extra=LIMITED),
                           HELMET.format(device=second, extra=LIMITED).replace("helmet:", "again:")])
    effects = "\n".join(["  brick: {actuator: helmet, inline: " + inline("b", "concrete-brick", "{type: memory}") + "}",
                         "  plate: {actuator: again, inline: " + inline("p", "steel-plate", "{type: memory}") + "}"])
    return _engine_case(case, actuators, effects, ["brick", "plate"], peak=0.3, rms=0.2, n=n, every_s=0.002)


def helmet_and_channel_0(n: int = 200) -> Verdict:
    effects = "\n".join(["  brick: {actuator: helmet, inline: " + inline("b", "concrete-brick", "{type: memory}") + "}",
                         "  plate: {actuator: helmet, channel: 0, inline: "
                         + inline("p", "steel-plate", "{type: memory}") + "}"])
    return _engine_case("scene actuator `helmet` and `helmet` channel 0", HELMET.format(device="default", extra=LIMITED),
                        effects, ["brick", "plate"], peak=0.3, rms=0.2, n=n, every_s=0.002)


def own_actuators(n: int = 200) -> Verdict:
    """Case 2: two effects, each with its own actuator section, on one device."""
    own = "{type: vibro-transducer, device: default, gain: 1.0, limits: {peak: 0.3, rms: 0.2}}"
    effects = "\n".join(["  brick: {inline: " + inline("b", "concrete-brick", own) + "}",
                         "  plate: {inline: " + inline("p", "steel-plate", own) + "}"])
    return _engine_case("two effects, each its own actuator, one device", "  {}", effects, ["brick", "plate"],
                        peak=0.3, rms=0.2, n=n, every_s=0.002)


def two_engines(n: int = 200) -> Verdict:
    return _engine_case("two Engines in one process", HELMET.format(device="default", extra=LIMITED),
                        "  brick: {actuator: helmet, inline: " + inline("b", "concrete-brick", "{type: memory}") + "}",
                        ["brick"], peak=0.3, rms=0.2, n=n, every_s=0.002, engines=2)


def queued_and_portaudio() -> Verdict:
    """Case 2: two actuators, queued and `queue: 0`, opened on one device and channel outside an engine:
    the second is refused with a clear error (each stream would limit only its own part of the sum)."""
    from ..actuator import VibroTransducer

    def build():
        first = VibroTransducer(VibroTransducer.Params(queue=0.15), BuildContext(device="default", channel=0))
        first.open()
        try:
            second = VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(device="default", channel=0))
            second.open()
            second.close()
        finally:
            first.close()
    return refused("a queued and a `queue: 0` actuator on one device and channel", build, 0.3, 0.2)


def routed_effect_limits(n: int = 100) -> Verdict:
    """Case 3: an effect with limits {peak: 0.2} routed by a scene to a shared actuator."""
    own = "{type: vibro-transducer, limits: {peak: 0.2}}"
    effects = "\n".join(["  brick: {actuator: helmet, inline: " + inline("b", "concrete-brick", own) + "}"])
    return _engine_case("effect limits {peak: 0.2} under a scene actuator",
                        HELMET.format(device="default", extra=""), effects, ["brick"], peak=0.2, rms=0.7, n=n,
                        every_s=0.01)


def other_rate(rate_hz: int, n: int = 100) -> Verdict:
    """Case 5: an actuator asking for another rate than the 48 kHz sink's."""
    return _engine_case(f"actuator at {rate_hz} Hz on a 48 kHz sink",
                        HELMET.format(device="default", extra=f", rate_hz: {rate_hz}, limits: {{peak: 0.3}}"),
                        "  brick: {actuator: helmet, inline: " + inline("b", "concrete-brick", "{type: memory}") + "}",
                        ["brick"], peak=0.3, rms=0.7, n=n, every_s=0.01)


def osc_flood(seconds: float = 10.0, scene: Path = REPO / "scenes" / "earthquake_room.yaml") -> Verdict:
    """Case 1: `hapticfx serve` on the shipped scene, unmodified (its port aside), flooded over UDP."""
    with Monitor() as monitor:
        proc = subprocess.Popen([sys.executable, "-m", "hapticfx", "serve", str(scene), "--port", "0"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ))
        try:
            line = proc.stdout.readline()
            if not line.startswith("listening on"):
                raise DeviceError(f"serve did not start: {line}{proc.stderr.read()[-500:]}")
            port = int(line.split()[2].rsplit(":", 1)[1])
            from hapticfx.osc import encode_impact

            objs = ["concrete-brick", "steel-plate", "wood-beam", "plastic-frame"]
            grams = [encode_impact(o, 2.0 + k) for k, o in enumerate(objs)]
            sent = 0
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
                end = time.monotonic() + seconds
                while time.monotonic() < end:
                    for g in grams:
                        client.sendto(g, ("127.0.0.1", port))
                    sent += len(grams)
        finally:
            proc.send_signal(signal.SIGINT)
            try:
                proc.communicate(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
    x = monitor.samples()
    return measure(f"OSC flood {seconds:g} s into serve earthquake_room.yaml", x, RATE, peak=1.0,
                   rms=0.7, tolerance=STEP, note=f"{sent} datagrams; {monitor.held}")


SOUNDCARD_CASES: dict[str, Callable[[], Verdict]] = {
    "queued-flood": queued_flood,
    "queued-flood-hard": lambda: queued_flood(limited=False),
    "osc-flood": osc_flood,
    "portaudio-flood": portaudio_flood,
    "helmet-and-channel-0": helmet_and_channel_0,
    "default-and-sink-name": lambda: twice("`default` and the sink's name (queue: 0.15)", "default, queue: 0.15",
                                           f"{sink_info(None)[0]}, queue: 0.15"),
    "pulse-and-default": lambda: twice("`pulse` and `default`", "pulse", "default"),
    "queued-and-portaudio": queued_and_portaudio,
    "queued-and-portaudio-scene": lambda: twice("scene: a queued and a `queue: 0` actuator, one device",
                                               "default", "default, queue: 0"),
    "own-actuators": own_actuators,
    "two-engines": two_engines,
    "routed-effect-limits": routed_effect_limits,
    "rate-8000": lambda: other_rate(8000),
    "rate-44100": lambda: other_rate(44100),
}

