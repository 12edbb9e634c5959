"""Measurements behind ``hapticfx bench output``.

Latency is read from a loopback capture: an input stream records the sound
server's monitor of the output device, and each impact's first sample is
found in it and timestamped with PortAudio's capture (ADC) clock, the same
clock that was read when the impact was submitted.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np
from hapticfx.errors import DeviceError
from hapticfx.interfaces import SafetyLimits

from ..devices import import_sounddevice
from ..mixer import Mixer
from .stallprobe import Stall, StallProbe

if TYPE_CHECKING:
    from ..actuator import SoundCardActuator

CLICK_LEVEL = 0.5
THRESHOLD = 0.25


@dataclass
class Capture:
    """Blocks recorded from an input device, with the ADC time of each block's first frame.

    Two flat lists, not a list of (time, block) pairs: a long capture would otherwise
    hold hundreds of thousands of tuples, which every full garbage collection walks
    with the GIL held, delaying the very audio callbacks being timed.
    """

    rate_hz: float
    blocks: list = field(default_factory=list)
    times: list = field(default_factory=list)

    def add(self, t0: float, block: np.ndarray) -> None:
        self.blocks.append(block)
        self.times.append(t0)

    def timeline(self, channel: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Samples of ``channel`` and the capture time of each."""
        if not self.blocks:
            raise DeviceError("the loopback capture recorded nothing")
        x = np.concatenate([b[:, channel] for b in self.blocks])
        t = np.concatenate([t0 + np.arange(b.shape[0]) / self.rate_hz for t0, b in zip(self.times, self.blocks)])
        return x, t


class LoopbackRecorder:
    """Records the monitor of the output device (the default input on the null sink)."""

    def __init__(self, rate_hz: float, *, device=None, channels: int = 2, latency: str | float = "low"):
        sd = import_sounddevice()
        self.capture = Capture(rate_hz)
        self.overflows = 0  # input blocks the machine did not take in time: a gap in the capture
        try:
            self._stream = sd.InputStream(device=device, samplerate=rate_hz, channels=channels,
                                          dtype="float32", latency=latency, callback=self._callback)
        except sd.PortAudioError as exc:
            raise DeviceError(f"cannot record the loopback monitor: {exc}") from None

    def _callback(self, indata, frames, time_info, status):
        if status.input_overflow:
            self.overflows += 1
        self.capture.add(time_info.inputBufferAdcTime, indata.copy())

    def now(self) -> float:
        """The capture stream's clock (seconds)."""
        return float(self._stream.time)

    def __enter__(self):
        self._stream.start()
        deadline = time.monotonic() + 2.0
        while not self.capture.blocks:  # a capture stream can take a while to deliver its first block
            if time.monotonic() > deadline:
                self.__exit__()
                raise DeviceError("the loopback monitor delivered nothing within 2 s")
            time.sleep(0.005)
        return self

    def __exit__(self, *exc):
        self._stream.stop()
        self._stream.close()
        return False


def onsets(x: np.ndarray, t: np.ndarray, *, threshold: float = THRESHOLD) -> np.ndarray:
    """Capture times at which ``|x|`` first rises above ``threshold`` after being below it."""
    above = np.abs(x) > threshold
    idx = np.flatnonzero(above[1:] & ~above[:-1]) + 1
    return t[idx]


def click(rate_hz: float) -> np.ndarray:
    """A 1 ms rectangular burst at half scale: a sharp, unambiguous onset."""
    return np.full(max(8, int(rate_hz / 1000)), CLICK_LEVEL)


@dataclass
class TimedPath:
    """One timed path: how to send an impact, and what it sends (filled in as it plays)."""

    name: str
    send: Callable[[float], None]
    channel: int
    signals: list = field(default_factory=list)  # what reached the device, in order (None: not played)
    calls: list = field(default_factory=list)    # capture-clock time of each send
    buffers_s: list = field(default_factory=list)  # the output's buffer at each send (lengthened after underflows)


@dataclass
class Rounds:
    """What ``send_rounds`` recorded: the monitor's capture, when the output underflowed during the
    sends (``time.monotonic()``), how many underflows came before them (streams settling), the
    machine's own stalls over the same time, the output's callbacks that came longer than its
    buffer after the one before (``(time, gap_s)``, during the sends), and how often the capture
    itself overflowed (a gap in the recording, where an onset can be missed)."""

    capture: Capture
    underflow_times: list[float]
    machine: StallProbe
    settling: int = 0
    late_callbacks: list[tuple[float, float]] = field(default_factory=list)
    capture_overflows: int = 0

    def gap_before(self, t: float, *, within_s: float = 0.005) -> float | None:
        """The longest late callback's gap (s) within ``within_s`` up to ``t`` (None: none)."""
        gaps = [gap for when, gap in self.late_callbacks if t - within_s <= when <= t]
        return max(gaps, default=None)

    def put_down_to_machine(self, *, within_s: float = 0.02, at_least_s: float = 0.005) -> list[Stall | None]:
        """For each underflow, the longest machine stall of at least ``at_least_s`` that ended
        within ``within_s`` before it was reported (None: no such stall)."""
        out = []
        for t in self.underflow_times:
            stall = self.machine.before(t, within_s=within_s)
            out.append(stall if stall is not None and stall.seconds >= at_least_s else None)
        return out


def send_rounds(paths: list[TimedPath], rate_hz: float, n: int, *, gap_s: float,
                output: SoundCardActuator, velocities=(2.45, 5.2),
                progress: Callable[[int], None] | None = None, seed: int = 0) -> Rounds:
    """Send ``n`` rounds while recording the monitor and probing the machine for stalls.

    Every round sends once on each path (in a rotating order), ``gap_s`` apart, at a
    velocity drawn from ``velocities``; each path notes the capture-clock time of each
    send and the output's buffer then. ``output`` (a sound-card actuator) gives its stream's
    buffer, underflow times and late callbacks. Nothing is analysed here: the outputs are
    still open, and an analysis running beside them would delay their audio callbacks.
    """
    rng = np.random.default_rng(seed)
    with LoopbackRecorder(rate_hz) as rec, StallProbe() as machine:
        time.sleep(0.3)
        start = time.monotonic()
        for i in range(n):
            k = i % len(paths)
            for p in paths[k:] + paths[:k]:
                v = float(rng.uniform(*velocities))
                p.calls.append(rec.now())
                p.buffers_s.append(output.output_latency_s)
                p.send(v)
                time.sleep(gap_s)
            if progress:
                progress(i + 1)
        every = output.underflow_times
        during = [t for t in every if t >= start]
        late = [(t, gap) for t, gap in output.late_callbacks if t >= start]
        time.sleep(0.3)
    return Rounds(rec.capture, during, machine, settling=len(every) - len(during), late_callbacks=late,
                  capture_overflows=rec.overflows)


def first_sample_latencies(paths: list[TimedPath], capture: Capture, *, gap_s: float) -> dict[str, np.ndarray]:
    """Seconds from each send to the first sample of what it played, per path.

    The onset of a played signal is where the capture first reaches half its peak;
    the time its own samples take to get there is subtracted, which gives the
    capture time of its first sample. NaN: not heard before the next send.
    """
    out = {}
    timelines = {}
    for p in paths:
        if p.channel not in timelines:
            timelines[p.channel] = capture.timeline(p.channel)
        x, t = timelines[p.channel]
        lat = []
        for t_call, sig in zip(p.calls, p.signals):
            if sig is None:
                lat.append(np.nan)
                continue
            peak = float(np.max(np.abs(sig)))
            lead = int(np.argmax(np.abs(sig) >= 0.5 * peak))  # samples from its first to half its peak
            lo, hi = np.searchsorted(t, [t_call, t_call + gap_s])  # the capture is in time order
            hit = np.flatnonzero(np.abs(x[lo:hi]) >= 0.5 * peak)
            lat.append(t[lo + hit[0]] - lead / capture.rate_hz - t_call if hit.size else np.nan)
        out[p.name] = np.array(lat)
    return out


def block_wall_times(voices: int, block: int, *, rate_hz: float = 48000.0, seconds: float = 1.0,
                     limits: SafetyLimits = SafetyLimits()) -> tuple[np.ndarray, np.ndarray]:
    """Wall seconds of each ``render_into`` (the audio callback's work) of ``block`` frames with
    ``voices`` impacts sounding at once, and of each ``add`` that queued them."""
    n = int(seconds * rate_hz)
    tt = np.arange(n) / rate_hz
    rng = np.random.default_rng(0)
    mixer = Mixer(1, rate_hz, max_voices=max(voices, 1))
    mixer.set_limits(0, limits)
    adds = []
    for _ in range(voices):
        signal = 0.3 * np.exp(-tt * 3.0) * np.sin(2 * np.pi * rng.uniform(40, 400) * tt) / max(1.0, voices ** 0.5)
        t0 = time.perf_counter()
        mixer.add(0, signal)
        adds.append(time.perf_counter() - t0)
    out = np.zeros((block, 1), dtype=np.float32)
    walls = []
    for _ in range(n // block):
        t0 = time.perf_counter()
        mixer.render_into(out)
        walls.append(time.perf_counter() - t0)
    return np.array(walls), np.array(adds)


def recovery_runs(mode: str, repeats: int, *, script: str, queue: float = 0.0,
                  progress: Callable[[str], None] | None = None) -> list[dict[str, str]]:
    """Run :mod:`hapticfx_soundcard.bench.faultprobe` ``repeats`` times in ``mode`` against a server of its own,
    its actuator with ``queue`` (0: the PortAudio stream)."""
    import os
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    from . import virtualserver

    runs = []
    for i in range(repeats):
        with tempfile.TemporaryDirectory(prefix="hapticfx-bench-") as runtime:
            env = {**os.environ, "HAPTICFX_XDG": runtime, "XDG_RUNTIME_DIR": runtime, "HAPTICFX_SOUNDSERVER": script}
            virtualserver.start(runtime, script)
            try:
                pid = (Path(runtime) / "pulse" / "pid").read_text().strip()
                done = subprocess.run([sys.executable, "-m", "hapticfx_soundcard.bench.faultprobe", mode, pid, str(queue)], env=env,
                                      capture_output=True, text=True, timeout=120)
            finally:
                virtualserver.stop(runtime)
        seen = dict(line.split(" ", 1) for line in done.stdout.splitlines() if " " in line)
        seen["returncode"] = str(done.returncode)
        runs.append(seen)
        if progress:
            progress(f"  {mode}, queue {queue:g} s, {i + 1}/{repeats}: back in {seen.get('recovered_s', '?')} s, heard {seen.get('heard', '?')}")
    return runs
