"""Android vibrations: the arguments of ``VibrationEffect.createWaveform`` and of the API 36 envelope builder.

Android has no file format for these: an app builds the effect in code. hapticfx writes the
arguments as JSON (``NAME.android.json``) for an app to pass on:

- ``waveform``: ``createWaveform(timings, amplitudes, repeat)``: timings in ms, amplitudes 0-255
  (0 is off; -1, ``DEFAULT_AMPLITUDE``, is read as 0.5 of full scale: Android leaves it to the
  device), ``repeat`` -1 (play once). Each breakpoint segment becomes one step at its mean
  amplitude. Every vibrator with amplitude control plays it.
- ``envelope``: ``VibrationEffect.WaveformEnvelopeBuilder`` (API 36): ``setInitialFrequencyHz``,
  then ``addControlPoint(amplitude 0-1, frequencyHz, durationMillis)`` per breakpoint; the builder
  starts at amplitude 0, so a signal loud at its first breakpoint rises to it in the first millisecond. Android documents no frequency range for all devices (an app reads the
  device's from ``Vibrator.getFrequencyProfile()``); an offline file cannot, so hapticfx writes
  the analysed frequency clamped to the export device's range (default Quest, 55-200 Hz). For the waveform itself, see :mod:`hapticfx.formats.ogg`.

Neither holds a transient: an onset stays in the envelope. Reading prefers ``envelope`` (it
holds the frequency) and falls back to ``waveform``; the rules checked are those the builders
enforce: equal lengths, timings >= 0 and not all 0, amplitudes 0-255 or -1, ``repeat`` -1 or an
index, control-point amplitudes 0-1, frequencies > 0, durations > 0.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import __version__
from .base import ExportOptions
from .device import Device
from .document import Reader
from .envelope_format import EnvelopeFormat
from .pattern import Curves, Pattern, grid_size, written

RULES = "Android VibrationEffect"
DEFAULT_AMPLITUDE = 0.5


class AndroidFormat(EnvelopeFormat):
    """``VibrationEffect.createWaveform`` and ``WaveformEnvelopeBuilder`` arguments."""

    name = "android"
    suffixes = (".android.json",)
    holds = frozenset({"envelope", "frequency"})
    description = "Android VibrationEffect waveform and API 36 envelope (arguments as JSON)"

    def document(self, pattern: Pattern, options: ExportOptions) -> Any:
        t, a = pattern.continuous()  # no burst: clipped to the impact's peak
        ms = np.round(t * 1000).astype(int)
        first = np.flatnonzero(np.concatenate(([True], np.diff(ms) > 0)))  # breakpoints a millisecond apart,
        ms, a, t = ms[first], np.maximum.reduceat(a, first), t[first]    # each the loudest of its millisecond
        timings = np.diff(ms).tolist()
        steps = np.floor(255 * 0.5 * (a[:-1] + a[1:])).astype(int).tolist()  # down: never above the peak
        if a[0] > 0 and len(ms) > 1 and ms[1] - ms[0] > 1:  # the envelope starts at 0: rise to a[0] in 1 ms
            ms, a, t = np.insert(ms, 1, ms[0] + 1), np.insert(a, 1, a[0]), np.insert(t, 1, t[0] + 1e-3)
            a[0] = 0.0
        elif len(ms) == 1 or a[0] > 0:  # nothing to take the millisecond from: 1 ms later
            ms, a, t = np.r_[ms[0], ms + 1], np.r_[0.0, a], np.r_[t[0], t + 1e-3]
        hz = options.device.hz(np.interp(t, pattern.frequency[:, 0], pattern.frequency[:, 1])
                               if len(pattern.frequency) else np.full(len(t), 0.5))
        points = [{"amplitude": written(a[i]), "frequencyHz": round(float(hz[i]), 3),
                   "durationMillis": int(ms[i] - ms[i - 1])} for i in range(1, len(ms))]
        return {"format": "android.os.VibrationEffect", "editor": f"hapticfx {__version__}",
                "device": options.device.name, "description": options.description,
                "waveform": {"timings": timings, "amplitudes": steps, "repeat": -1},
                "envelope": {"initialFrequencyHz": round(float(hz[0]), 3), "controlPoints": points}}

    def curves(self, doc: Any, source: str, device: Device, rate_hz: float) -> tuple[Curves, list[str]]:
        r = Reader(source, RULES)
        if not isinstance(doc, dict):
            r.fail("$", f"expected an object, got {type(doc).__name__}", "structure")
        if "envelope" not in doc and "waveform" not in doc:
            r.fail("$", "neither 'envelope' nor 'waveform'", "a vibration needs a waveform or an envelope")
        waveform = self._waveform(r, doc["waveform"]) if "waveform" in doc else None
        if "envelope" in doc:
            return self._envelope(r, doc["envelope"], device, rate_hz)
        timings, amplitudes = waveform
        ends = np.cumsum(timings) / 1000.0
        n = grid_size(float(ends[-1]), rate_hz, r.source)
        grid = np.arange(n) / rate_hz
        idx = np.minimum(np.searchsorted(ends, grid, side="right"), len(amplitudes) - 1)
        amp = np.where(np.asarray(amplitudes) < 0, DEFAULT_AMPLITUDE, np.asarray(amplitudes) / 255.0)[idx]
        return Curves(rate_hz, amp, np.full(n, 0.5)), []

    def _waveform(self, r: Reader, node) -> tuple[list, list]:
        where = "$.waveform"
        timings = r.array(r.key(node, "timings", where), f"{where}.timings")
        amplitudes = r.array(r.key(node, "amplitudes", where), f"{where}.amplitudes")
        if len(timings) != len(amplitudes):
            r.fail(where, f"{len(timings)} timings and {len(amplitudes)} amplitudes", "timings and amplitudes of equal length")
        for i, v in enumerate(timings):
            if r.number(v, f"{where}.timings[{i}]", integer=True) < 0:
                r.fail(f"{where}.timings[{i}]", f"timing {v} is negative", "timings >= 0 ms")
        for i, v in enumerate(amplitudes):
            v = r.number(v, f"{where}.amplitudes[{i}]", integer=True)
            if not (0 <= v <= 255 or v == -1):
                r.fail(f"{where}.amplitudes[{i}]", f"amplitude {v} is out of range", "amplitudes 0-255 or -1 (DEFAULT_AMPLITUDE)")
        if not timings or sum(timings) <= 0:
            r.fail(f"{where}.timings", "the waveform has zero duration", "total duration > 0")
        repeat = r.number(node.get("repeat", -1), f"{where}.repeat", integer=True)
        if not -1 <= repeat < len(timings):
            r.fail(f"{where}.repeat", f"repeat {repeat} is not -1 or an index of timings", "repeat -1 or an index")
        return timings, amplitudes

    def _envelope(self, r: Reader, node, device: Device, rate_hz: float) -> tuple[Curves, list[str]]:
        where = "$.envelope"
        points = r.array(r.key(node, "controlPoints", where), f"{where}.controlPoints")
        if not points:
            r.fail(f"{where}.controlPoints", "no control point", "at least one control point")
        t, amp, hz = [0.0], [0.0], []
        for i, p in enumerate(points):
            at = f"{where}.controlPoints[{i}]"
            amp.append(r.ranged(r.key(p, "amplitude", at), f"{at}.amplitude", 0.0, 1.0, "amplitude 0-1"))
            f = r.number(r.key(p, "frequencyHz", at), f"{at}.frequencyHz")
            if f <= 0:
                r.fail(f"{at}.frequencyHz", f"frequency {f:g} Hz", "frequencies > 0 Hz")
            d = r.number(r.key(p, "durationMillis", at), f"{at}.durationMillis", integer=True)
            if d <= 0:
                r.fail(f"{at}.durationMillis", f"duration {d} ms", "durations > 0 ms")
            hz.append(f)
            t.append(t[-1] + d / 1000.0)
        first = node.get("initialFrequencyHz", hz[0])
        if r.number(first, f"{where}.initialFrequencyHz") <= 0:
            r.fail(f"{where}.initialFrequencyHz", f"frequency {first:g} Hz", "frequencies > 0 Hz")
        hz = np.array([float(first)] + hz)
        notes = []
        outside = int(np.count_nonzero((hz < device.frequency_min_hz) | (hz > device.frequency_max_hz)))
        if outside:
            notes.append(f"{r.source}: {outside} frequency value(s) outside the device's {device.frequency_min_hz:g}-"
                         f"{device.frequency_max_hz:g} Hz, played at its nearest edge")
        pattern = Pattern(np.column_stack((t, amp)), np.column_stack((t, device.normalised(hz))))
        return pattern.curves(rate_hz, r.source), notes
