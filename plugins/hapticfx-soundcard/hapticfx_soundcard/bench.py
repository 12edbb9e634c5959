"""Measurements behind ``hapticfx bench output``.

Latency is read from a loopback capture: an input stream records the sound
server's monitor of the output device, and each impact's first sample is
found in it and timestamped with PortAudio's capture (ADC) clock, the same
clock that was read when ``play`` was called.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from hapticfx.errors import DeviceError
from hapticfx.interfaces import SafetyLimits

from .devices import import_sounddevice
from .mixer import Mixer

CLICK_LEVEL = 0.5
THRESHOLD = 0.25


@dataclass
class Capture:
    """Blocks recorded from an input device, with the ADC time of each block's first frame."""

    rate_hz: float
    blocks: list

    def timeline(self, channel: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Samples of ``channel`` and the capture time of each."""
        if not self.blocks:
            raise DeviceError("the loopback capture recorded nothing")
        x = np.concatenate([b[:, channel] for _, b in self.blocks])
        t = np.concatenate([t0 + np.arange(b.shape[0]) / self.rate_hz for t0, b in self.blocks])
        return x, t


class LoopbackRecorder:
    """Records the monitor of the output device (the default input on the null sink)."""

    def __init__(self, rate_hz: float, *, device=None, channels: int = 2):
        sd = import_sounddevice()
        self.capture = Capture(rate_hz, [])
        try:
            self._stream = sd.InputStream(device=device, samplerate=rate_hz, channels=channels,
                                          dtype="float32", latency="low", callback=self._callback)
        except sd.PortAudioError as exc:
            raise DeviceError(f"cannot record the loopback monitor: {exc}") from None

    def _callback(self, indata, frames, time_info, status):
        self.capture.blocks.append((time_info.inputBufferAdcTime, indata.copy()))

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


def first_sample_latencies(play: Callable[[np.ndarray], None], rate_hz: float, n: int, *,
                           gap_s: float = 0.25, progress: Callable[[int], None] | None = None) -> np.ndarray:
    """Seconds from each ``play(click)`` call to its first sample in the loopback capture.

    NaN for a click not heard before the next one was played (``gap_s`` later).
    """
    signal = click(rate_hz)
    calls = []
    with LoopbackRecorder(rate_hz) as rec:
        time.sleep(0.3)
        for i in range(n):
            calls.append(rec.now())
            play(signal)
            time.sleep(gap_s)
            if progress:
                progress(i + 1)
        time.sleep(0.3)
    x, t = rec.capture.timeline(0)
    heard = onsets(x, t)
    out = []
    for t_call in calls:
        later = heard[(heard >= t_call) & (heard < t_call + gap_s)]
        out.append(later[0] - t_call if later.size else np.nan)
    return np.array(out)


def mix_real_time_factor(voices: int, *, rate_hz: float = 48000.0, block: int = 256,
                         seconds: float = 1.0, limits: SafetyLimits = SafetyLimits()) -> float:
    """Audio seconds mixed per CPU second with ``voices`` impacts sounding at once, on one core."""
    n = int(seconds * rate_hz)
    tt = np.arange(n) / rate_hz
    rng = np.random.default_rng(0)
    mixer = Mixer(1, rate_hz, max_voices=voices)
    mixer.set_limits(0, limits)
    for _ in range(voices):
        f = rng.uniform(40, 400)
        mixer.add(0, 0.3 * np.exp(-tt * 3.0) * np.sin(2 * np.pi * f * tt))
    out = np.zeros((block, 1), dtype=np.float32)
    start = time.process_time()
    for _ in range(n // block):
        mixer.render_into(out)
    cpu = time.process_time() - start
    return (n // block) * block / rate_hz / max(cpu, 1e-9)
