"""Playing a parametric haptic description: an oscillator under the envelope, emphasis as short bursts.

The synthesis follows what Meta's renderer documents for PCM devices (meta-haptics-sdk
resources/acf/README.md and its continuous oscillator): a sine whose frequency is the
0-1 frequency mapped linearly onto the device's ``frequency_min``-``frequency_max``, phase
kept continuous as the frequency moves, times the amplitude envelope and the device's
gain. An emphasis is a burst of ``emphasis.duration_ms`` at ``emphasis.output_frequency``,
both moved from the device's ``frequency_min`` end to its ``frequency_max`` end by the
emphasis' 0-1 frequency, its wave shape crossfaded the same way (Quest: a 36.4 ms sine at
55 Hz to a 12.1 ms square at 165 Hz), faded out by ``fade_out_percent``; while it plays,
the continuous signal is multiplied by ``emphasis_ducking``. The result is a fraction of
the actuator's full range, clipped to it; the pipeline shapes and limits it like any other model output.
"""

from __future__ import annotations

import numpy as np

from .device import Device
from .pattern import Curves


def wave(shape: str, cycles: np.ndarray) -> np.ndarray:
    """One of the ACF wave shapes at phase ``cycles`` (in cycles, 0 = start of a rising sine)."""
    if shape == "sine":
        return np.sin(2 * np.pi * cycles)
    if shape == "square":
        return np.where((cycles % 1.0) < 0.5, 1.0, -1.0)
    if shape == "triangle":
        return 2 / np.pi * np.arcsin(np.sin(2 * np.pi * cycles))
    if shape == "saw":
        return 2.0 * (cycles % 1.0) - 1.0
    raise ValueError(f"unknown wave shape {shape!r}")


def synthesize(curves: Curves, device: Device) -> np.ndarray:
    """The signal ``curves`` describe on ``device``, at ``curves.rate_hz`` (longer when a burst outlasts them)."""
    rate = curves.rate_hz
    hz = device.hz(np.clip(curves.frequency, 0.0, 1.0))
    cycles = np.concatenate(([0.0], np.cumsum(hz[:-1]) / rate))
    continuous = device.gain * np.clip(curves.amplitude, 0.0, 1.0) * np.sin(2 * np.pi * cycles)
    ends = [len(continuous)]
    bursts = []
    lo, hi = device.emphasis_min, device.emphasis_max
    for e in curves.emphasis:
        s = float(np.clip(e.frequency, 0.0, 1.0))
        freq = device.burst_hz(s)
        dur = device.burst_ms(s) / 1000.0
        start = max(0, int(round(e.time_s * rate)))  # a burst before the start plays at the start
        count = max(1, int(round(dur * rate)))
        t = np.arange(count) / rate
        shape = (1 - s) * wave(lo.shape, freq * t) + s * wave(hi.shape, freq * t)
        fade = 1.0 - device.emphasis_fade_out * t / dur
        bursts.append((start, device.emphasis_gain * float(np.clip(e.amplitude, 0.0, 1.0)) * shape * fade))
        ends.append(start + count)
    out = np.zeros(max(ends))
    out[: len(continuous)] = continuous
    for start, burst in bursts:
        seg = slice(start, start + len(burst))
        out[seg] *= device.emphasis_ducking
    for start, burst in bursts:
        out[start:start + len(burst)] += burst
    return np.clip(out, -1.0, 1.0)  # an actuator's full scale; an emphasis on a loud envelope reaches it
