"""MPEG-I Haptics interchange, ``.hjif`` (ISO/IEC 23090-31), as far as MPEG's public reference software reads it.

The standard's JSON schema is not public. This module follows the structure that
MPEGGroup/HapticReferenceSoftware (BSD-3) loads and checks in
``source/IOHaptics/src/IOJson.cpp`` (the version at commit 73ffe9bb, for the 2023 edition):
top-level ``version`` (``YYYY`` or ``YYYY-N``, year >= 2023), ``profile`` (``Main`` or
``Simple Parametric``), ``level`` (1 or 2), ``date``, ``description``, ``timescale`` (ticks per
second; <= 48000 for Main, 1000 for Simple Parametric), ``avatars``, ``syncs`` and
``perceptions``; a perception has ``id``, ``avatar_id``, ``description``,
``perception_modality``, ``effect_library`` and ``channels``; a channel ``id``,
``description``, ``gain``, ``mixing_coefficient``, ``body_part_mask`` and ``bands``; a band
``band_type`` (``Curve``, ``Transient``, ``VectorialWave``, ``WaveletWave``),
``lower_frequency_limit``, ``upper_frequency_limit`` (integers, Hz) and ``effects``; an effect
``effect_type`` (``Basis``), ``position`` (ticks), ``phase``, ``base_signal`` and ``keyframes``;
a keyframe ``relative_position`` (ticks), ``amplitude_modulation`` and ``frequency_modulation``
(integer Hz). Where the reference loader skips a malformed entry with a message, this reader
refuses the file.

hapticfx writes one Vibrotactile perception, one channel (``body_part_mask`` 0, unspecified:
the mask's bit for the head could not be checked), a ``VectorialWave`` band whose one sine
effect carries the amplitude breakpoints with their frequency in Hz, and a ``Transient`` band
for an onset emphasis (its frequency the burst's Hz). The burst is played over a continuous signal only
ducked, so the keyframes stay at 0 until the first tick at or after the burst ends as the export device
plays it (its length follows from the integer Hz written) and come back one tick later; amplitudes are
clipped to the impact's peak and rounded down: read back on that device, the file stays within the
limited impact (tests/test_formats.py). Reading renders ``VectorialWave``
keyframes as a sine at their Hz under their amplitude (Hz outside the reading device's range
are played at its nearest edge) and ``Transient`` effects as emphasis bursts; ``Curve`` bands
(a low-frequency signal of its own) and ``WaveletWave`` bands (the codec's residual) are not
rendered, said in one line. What could not be checked: the
schema itself, whether the reference synthesiser interpolates keyframes linearly as hapticfx
does, and the reference encoder's own reading of these files (not built here).
"""

from __future__ import annotations

import re
from datetime import date
from typing import Any

import numpy as np

from .. import __version__
from .base import ExportOptions
from .device import Device
from .document import Reader
from .envelope_format import EnvelopeFormat
from .pattern import Curves, Emphasis, Pattern, grid_size, written

RULES = "HJIF (MPEG reference software)"
VERSION = "2023"
TIMESCALE = 1000
BANDS = ("Curve", "Transient", "VectorialWave", "WaveletWave")


class HjifFormat(EnvelopeFormat):
    """MPEG-I Haptics JSON interchange format."""

    name = "hjif"
    suffixes = (".hjif",)
    holds = frozenset({"envelope", "frequency", "transients"})
    description = "MPEG-I Haptics .hjif (ISO/IEC 23090-31), reference-software structure"

    def document(self, pattern: Pattern, options: ExportOptions) -> Any:
        dev = options.device
        lo, hi = dev.emphasis_min, dev.emphasis_max
        burst_hz = [int(round(dev.burst_hz(e.frequency))) for e in pattern.emphasis]
        t, a = pattern.continuous([(e.time_s, e.end_s(dev, _burst_frequency(f, dev)))
                                   for e, f in zip(pattern.emphasis, burst_hz)], TIMESCALE)
        hz = dev.hz(np.interp(t, pattern.frequency[:, 0], pattern.frequency[:, 1]) if len(pattern.frequency)
                    else np.full(len(t), 0.5))
        ticks = np.round(t * TIMESCALE).astype(int)
        keep = np.concatenate(([True], np.diff(ticks) > 0))
        keyframes = [{"relative_position": int(p), "amplitude_modulation": written(v),
                      "frequency_modulation": int(round(f))} for p, v, f in zip(ticks[keep], a[keep], hz[keep])]
        bands = [{"band_type": "VectorialWave", "curve_type": "Linear",
                  "lower_frequency_limit": int(np.floor(dev.frequency_min_hz)),
                  "upper_frequency_limit": int(np.ceil(dev.frequency_max_hz)),
                  "effects": [{"id": 0, "effect_type": "Basis", "position": 0, "phase": 0.0, "base_signal": "Sine",
                               "keyframes": keyframes}]}]
        if pattern.emphasis:
            bands.append({"band_type": "Transient",
                          "lower_frequency_limit": int(np.floor(min(lo.frequency_hz, hi.frequency_hz))),
                          "upper_frequency_limit": int(np.ceil(max(lo.frequency_hz, hi.frequency_hz))),
                          "effects": [{"id": i + 1, "effect_type": "Basis", "position": int(round(e.time_s * TIMESCALE)),
                                       "phase": 0.0, "base_signal": "Sine", "keyframes": [{
                                           "relative_position": 0,
                                           "amplitude_modulation": written(min(e.amplitude, pattern.peak)),
                                           "frequency_modulation": f}]}
                                      for i, (e, f) in enumerate(zip(pattern.emphasis, burst_hz))]})
        return {"version": VERSION, "profile": "Main", "level": 1, "date": date.today().isoformat(),
                "description": options.description or f"exported by hapticfx {__version__}", "timescale": TIMESCALE,
                "avatars": [], "syncs": [],
                "perceptions": [{"id": 0, "avatar_id": 0, "description": "impact (hapticfx)",
                                 "perception_modality": "Vibrotactile", "effect_library": [],
                                 "reference_devices": [{"id": 0, "name": f"hapticfx device {dev.name}",
                                                        "minimum_frequency": dev.frequency_min_hz,
                                                        "maximum_frequency": dev.frequency_max_hz}],
                                 "channels": [{"id": 0, "description": "crown", "reference_device_id": 0, "gain": 1.0,
                                               "mixing_coefficient": 1.0, "body_part_mask": 0, "bands": bands}]}]}

    def curves(self, doc: Any, source: str, device: Device, rate_hz: float) -> tuple[Curves, list[str]]:
        r = Reader(source, RULES)
        for key in ("version", "profile", "level", "date", "description", "timescale", "perceptions", "avatars", "syncs"):
            r.key(doc, key, "$")
        version = doc["version"]
        m = re.fullmatch(r"([0-9]{4})(-([0-9]+))?", version) if isinstance(version, str) else None
        if not m or int(m.group(1)) < 2023 or (m.group(3) is not None and int(m.group(3)) <= 0):
            r.fail("$.version", f"version {version!r}", "version YYYY or YYYY-N, year >= 2023")
        if doc["profile"] not in ("Main", "Simple Parametric"):
            r.fail("$.profile", f"profile {doc['profile']!r}", "profile Main or Simple Parametric")
        if doc["level"] not in (1, 2) or isinstance(doc["level"], bool):
            r.fail("$.level", f"level {doc['level']!r}", "level 1 or 2")
        scale = r.number(doc["timescale"], "$.timescale", integer=True)
        if scale <= 0 or (doc["profile"] == "Main" and scale > 48000) or (doc["profile"] != "Main" and scale != 1000):
            r.fail("$.timescale", f"timescale {scale}", "timescale > 0, <= 48000 (Main), 1000 (Simple Parametric)")
        r.array(doc["avatars"], "$.avatars")
        r.array(doc["syncs"], "$.syncs")
        parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (times, amplitude, hz)
        emphasis: list[tuple[float, float, float]] = []
        notes: list[str] = []
        skipped = set()
        for i, perception in enumerate(r.array(doc["perceptions"], "$.perceptions")):
            at = f"$.perceptions[{i}]"
            r.number(r.key(perception, "id", at), f"{at}.id", integer=True)
            r.number(r.key(perception, "avatar_id", at), f"{at}.avatar_id", integer=True)
            for key in ("description", "perception_modality"):
                if not isinstance(r.key(perception, key, at), str):
                    r.fail(f"{at}.{key}", "expected a string", "types")
            r.array(r.key(perception, "effect_library", at), f"{at}.effect_library")
            channels = r.array(r.key(perception, "channels", at), f"{at}.channels")
            if perception["perception_modality"] != "Vibrotactile":
                skipped.add(f"{perception['perception_modality']} perception")
                continue
            for j, channel in enumerate(channels):
                cat = f"{at}.channels[{j}]"
                r.number(r.key(channel, "id", cat), f"{cat}.id", integer=True)
                gain = r.number(r.key(channel, "gain", cat), f"{cat}.gain") * r.number(
                    r.key(channel, "mixing_coefficient", cat), f"{cat}.mixing_coefficient")
                r.number(r.key(channel, "body_part_mask", cat), f"{cat}.body_part_mask", integer=True)
                for k, band in enumerate(r.array(r.key(channel, "bands", cat), f"{cat}.bands")):
                    self._band(r, band, f"{cat}.bands[{k}]", scale, gain, parts, emphasis, skipped)
        if not parts and not emphasis:
            r.fail("$.perceptions", "no vibrotactile keyframe to play", "a file to play holds a vibrotactile band")
        if skipped:
            notes.append(f"{source}: not rendered: {', '.join(sorted(skipped))}")
        return self._render(parts, emphasis, device, rate_hz, source), notes

    def _band(self, r, band, at, scale, gain, parts, emphasis, skipped) -> None:
        btype = r.key(band, "band_type", at)
        if btype not in BANDS:
            r.fail(f"{at}.band_type", f"band type {btype!r}", f"band_type one of {', '.join(BANDS)}")
        for key in ("lower_frequency_limit", "upper_frequency_limit"):
            r.number(r.key(band, key, at), f"{at}.{key}", integer=True)
        effects = r.array(r.key(band, "effects", at), f"{at}.effects")
        if btype in ("WaveletWave", "Curve"):
            skipped.add(f"{btype} bands")
            return
        for e, effect in enumerate(effects):
            eat = f"{at}.effects[{e}]"
            etype = r.key(effect, "effect_type", eat)
            if etype != "Basis":
                skipped.add(f"{etype} effects")
                continue
            position = r.number(r.key(effect, "position", eat), f"{eat}.position", integer=True)
            r.number(r.key(effect, "phase", eat), f"{eat}.phase")
            if not isinstance(r.key(effect, "base_signal", eat), str):
                r.fail(f"{eat}.base_signal", "expected a string", "types")
            times, amps, hzs = [], [], []
            last_f = None
            for q, kf in enumerate(r.array(r.key(effect, "keyframes", eat), f"{eat}.keyframes")):
                kat = f"{eat}.keyframes[{q}]"
                if not isinstance(kf, dict):
                    r.fail(kat, f"expected an object, got {type(kf).__name__}", "structure")
                rel = r.number(kf.get("relative_position", 0), f"{kat}.relative_position", integer=True)
                amp = r.number(kf.get("amplitude_modulation", amps[-1] if amps else 0.0), f"{kat}.amplitude_modulation")
                if "frequency_modulation" in kf:
                    last_f = r.number(kf["frequency_modulation"], f"{kat}.frequency_modulation", integer=True)
                if times and (position + rel) / scale < times[-1]:
                    r.fail(f"{kat}.relative_position", "keyframes out of time order", "keyframes in time order")
                times.append((position + rel) / scale)
                amps.append(amp)
                hzs.append(last_f)
            if not times:
                continue
            if btype == "Transient":
                emphasis.append((times[0], abs(amps[0]) * gain, hzs[0] if hzs[0] is not None else 0.0))
            else:
                hz = np.array([np.nan if f is None else f for f in hzs], dtype=float)
                parts.append((np.array(times), np.array(amps) * gain, hz))

    def _render(self, parts, emphasis, device: Device, rate_hz: float, source: str) -> Curves:
        burst = max(device.emphasis_min.duration_ms, device.emphasis_max.duration_ms) / 1000
        end = max([p[0][-1] for p in parts] + [e[0] + burst for e in emphasis] + [1.0 / rate_hz])
        n = grid_size(end, rate_hz, source)
        grid = np.arange(n) / rate_hz
        amplitude = np.zeros(n)
        hz = np.full(n, device.hz(0.5))
        for times, amps, f in parts:
            on = (grid >= times[0]) & (grid <= times[-1])
            a = np.where(on, np.interp(grid, times, amps), 0.0)
            known = np.isfinite(f)
            if known.any():
                hz = np.where(on & (np.abs(a) > amplitude), np.interp(grid, times[known], f[known]), hz)
            amplitude = amplitude + np.abs(a)
        freq = device.normalised(hz)
        emph = tuple(Emphasis(t, min(1.0, a), _burst_frequency(f, device)) for t, a, f in sorted(emphasis))
        return Curves(rate_hz, np.minimum(amplitude, 1.0), freq, emph)


def _burst_frequency(hz: float, device: Device) -> float:
    """A ``Transient`` effect's Hz as the 0-1 emphasis frequency ``device`` plays it at (its length follows)."""
    lo, hi = device.emphasis_min.frequency_hz, device.emphasis_max.frequency_hz
    return float(np.clip((hz - lo) / (hi - lo), 0, 1)) if hi > lo else 0.5
