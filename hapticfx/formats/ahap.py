"""Apple's AHAP (Core Haptics, "Representing haptic patterns in AHAP files"): transient and continuous events,
intensity and sharpness, parameter curves.

**Mapping.** Apple documents no Hz for sharpness, and intensity is perceptual, not linear. hapticfx
follows Meta's own ``.haptic``-to-AHAP conversion (meta-haptics-sdk core/haptic_data/src/ahap.rs):
intensity = sqrt(amplitude) and sharpness = sqrt(0-1 frequency), that 0-1 frequency being the
device's (default Quest: 55-200 Hz); reading inverts both. A file therefore carries no carrier
frequency of its own: it carries a sharpness that the reading device turns into one.

**Writing.** One ``HapticContinuous`` event per 30 s (Core Haptics' longest) at intensity 1 and
sharpness 0, shaped by ``HapticIntensityControl`` curves (multiplicative, 0-1) and
``HapticSharpnessControl`` curves (additive, -1-1), at most 16 control points each (consecutive
curves continue one another; Core Haptics is reported to refuse longer curves); an onset
emphasis becomes a ``HapticTransient``. A parameter curve applies to every event of a pattern,
transients included, so the intensity curve holds the transient's level at its instant; a burst plays
over a continuous event ducked, not silenced, so no continuous event plays from just before the
transient until the first millisecond at or after its burst ends on the export device (the curve
rises back over the next), and intensities are clipped to the impact's peak and rounded down: read
back on that device, the file stays within the limited impact (tests/test_formats.py).

**Reading** as Core Haptics does: JSON5 (trailing commas, comments), missing keys set to
defaults (intensity 1, sharpness 0.5, time 0: Apple states no defaults for these; we chose the
strongest and the middle), out-of-range values clamped (one warning), unknown keys ignored.
``AudioCustom`` and ``AudioContinuous`` events are sound: left out, said in one line.
``AttackTime``/``ReleaseTime`` become linear ramps at a continuous event's ends; ``DecayTime``
and ``Sustained`` are not rendered (said in one line). What Core Haptics cannot load is refused:
text that is not JSON5, a pattern that is not an array, an event without an ``EventType``, a
continuous event without a duration, a value of the wrong type, no haptic event at all.
"""

from __future__ import annotations

from datetime import date
from typing import Any

import numpy as np

from .. import __version__
from .base import ExportOptions
from .device import Device
from .document import Reader
from .envelope_format import EnvelopeFormat
from .pattern import MILLISECONDS, Curves, Emphasis, Pattern, first_tick, grid_size, written

RULES = "AHAP"
MAX_CONTINUOUS_S = 30.0
MAX_CURVE_POINTS = 16
AUDIO_EVENTS = ("AudioCustom", "AudioContinuous")
CONTROLS = {"HapticIntensityControl": (0.0, 1.0, 1.0), "HapticSharpnessControl": (-1.0, 1.0, 0.0)}
DEFAULTS = {"HapticIntensity": 1.0, "HapticSharpness": 0.5}
EARLY_S = 0.00005  # a reader starts a burst on its nearest sample: up to 50 us early at 10 kHz or more (whole-ms times: on time at whole kHz)


def _r(x: float) -> float:
    return round(float(x), 6)


def _curves(parameter: str, times: np.ndarray, values: np.ndarray) -> list[dict]:
    """``ParameterCurve`` entries through (times, values), at most 16 control points each."""
    out = []
    start = 0
    while start < len(times) - 1 or not out:
        stop = min(len(times), start + MAX_CURVE_POINTS)
        t0 = float(times[start])
        points = [{"Time": _r(t - t0), "ParameterValue": _r(v)} for t, v in zip(times[start:stop], values[start:stop])]
        out.append({"ParameterCurve": {"ParameterID": parameter, "Time": _r(t0), "ParameterCurveControlPoints": points}})
        start = stop - 1
        if stop == len(times):
            break
    return out


class AhapFormat(EnvelopeFormat):
    """Apple Haptic and Audio Pattern (iPhone, Apple Vision)."""

    name = "ahap"
    suffixes = (".ahap",)
    holds = frozenset({"envelope", "transients"})  # sharpness, not a frequency
    description = "Apple AHAP (Core Haptics: iPhone, Apple Vision)"
    lenient = True

    def document(self, pattern: Pattern, options: ExportOptions) -> Any:
        dev = options.device
        f = pattern.frequency
        shifts = [float(np.interp(e.time_s, f[:, 0], np.sqrt(np.clip(f[:, 1], 0.0, 1.0)))) if len(f) else 0.0
                  for e in pattern.emphasis]
        sharpness = [_r(np.clip(np.sqrt(np.clip(e.frequency, 0.0, 1.0)) - shift, 0.0, 1.0))  # the curve adds to it
                     for e, shift in zip(pattern.emphasis, shifts)]
        # What the burst plays at (and so how long it lasts): the sharpness written plus the curve's, squared.
        ends = [e.end_s(dev, float(np.clip(s + shift, 0.0, 1.0)) ** 2)
                for e, s, shift in zip(pattern.emphasis, sharpness, shifts)]
        times, amplitude = pattern.continuous([(e.time_s, end) for e, end in zip(pattern.emphasis, ends)], MILLISECONDS)
        intensity = np.sqrt(amplitude)
        transients = []
        gaps = []
        for e, s, end in zip(pattern.emphasis, sharpness, ends):
            # Curves scale transients too: the intensity curve holds the transient's level at its instant, and no
            # continuous event plays from just before it until the envelope comes back after the burst.
            intensity[np.flatnonzero(times == e.time_s)[0]] = np.sqrt(min(e.amplitude, pattern.peak, 1.0))
            gaps.append((e.time_s - EARLY_S, first_tick(end, MILLISECONDS)))
            transients.append({"Event": {"Time": _r(e.time_s), "EventType": "HapticTransient", "EventParameters": [
                {"ParameterID": "HapticIntensity", "ParameterValue": 1.0},
                {"ParameterID": "HapticSharpness", "ParameterValue": s}]}})
        intensity = np.array([written(v) for v in intensity])
        total = float(times[-1])
        events = []
        for start, stop in _spans(total, gaps):
            while start < stop or not events and not gaps:  # a pattern without a transient has one event at least
                events.append({"Event": {"Time": _r(start), "EventType": "HapticContinuous",
                                         "EventDuration": _r(min(MAX_CONTINUOUS_S, stop - start)), "EventParameters": [
                                             {"ParameterID": "HapticIntensity", "ParameterValue": 1.0},
                                             {"ParameterID": "HapticSharpness", "ParameterValue": 0.0}]}})
                start += MAX_CONTINUOUS_S
        pattern_entries = events + _curves("HapticIntensityControl", times, intensity)
        if len(f):
            pattern_entries += _curves("HapticSharpnessControl", f[:, 0], np.sqrt(np.clip(f[:, 1], 0.0, 1.0)))
        return {"Version": 1.0,
                "Metadata": {"Project": "hapticfx", "Created": date.today().isoformat(),
                             "Description": options.description or "exported by hapticfx",
                             "Created By": f"hapticfx {__version__} (device {options.device.name})"},
                "Pattern": pattern_entries + transients}

    def curves(self, doc: Any, source: str, device: Device, rate_hz: float) -> tuple[Curves, list[str]]:
        r = Reader(source, RULES)
        if not isinstance(doc, dict):
            r.fail("$", f"expected an object, got {type(doc).__name__}", "structure")
        entries = r.array(doc.get("Pattern", []), "$.Pattern")
        clamped: list[str] = []
        ignored: set[str] = set()
        audio = 0
        envelope_only: set[str] = set()

        def value(node, where, lo, hi, default):
            if node is None:
                return default
            v = r.number(node, where)
            if not lo <= v <= hi:
                clamped.append(where)
                v = min(max(v, lo), hi)
            return v

        continuous, transients = [], []
        controls: dict[str, list] = {k: [] for k in CONTROLS}
        for i, entry in enumerate(entries):
            at = f"$.Pattern[{i}]"
            if not isinstance(entry, dict):
                r.fail(at, f"expected an object, got {type(entry).__name__}", "structure")
            for kind, body in entry.items():
                where = f"{at}.{kind}"
                if kind == "Event":
                    etype = r.key(body, "EventType", where)
                    if not isinstance(etype, str):
                        r.fail(f"{where}.EventType", f"expected a string, got {etype!r}"[:80], "types")
                    if etype in AUDIO_EVENTS:
                        audio += 1
                        continue
                    if etype not in ("HapticTransient", "HapticContinuous"):
                        ignored.add(f"EventType {etype}")
                        continue
                    t = value(body.get("Time"), f"{where}.Time", 0.0, 1e6, 0.0)
                    params = {}
                    for j, p in enumerate(r.array(body.get("EventParameters", []), f"{where}.EventParameters")):
                        pid = _name(r, r.key(p, "ParameterID", f"{where}.EventParameters[{j}]"),
                                    f"{where}.EventParameters[{j}].ParameterID")
                        pv = r.key(p, "ParameterValue", f"{where}.EventParameters[{j}]")
                        pwhere = f"{where}.EventParameters[{j}].ParameterValue"
                        if pid in DEFAULTS:
                            params[pid] = value(pv, pwhere, 0.0, 1.0, DEFAULTS[pid])
                        elif pid in ("AttackTime", "ReleaseTime"):
                            params[pid] = value(pv, pwhere, 0.0, 1e3, 0.0)
                        elif pid in ("DecayTime", "Sustained"):
                            envelope_only.add(str(pid))
                        else:
                            ignored.add(f"ParameterID {pid}")
                    if etype == "HapticTransient":
                        transients.append((t, params))
                    else:
                        if "EventDuration" not in body:
                            r.fail(where, "a continuous event without EventDuration",
                                   "continuous events must have a duration")
                        d = value(body["EventDuration"], f"{where}.EventDuration", 0.0, MAX_CONTINUOUS_S, 0.0)
                        continuous.append((t, d, params))
                elif kind in ("Parameter", "ParameterCurve"):
                    pid = _name(r, r.key(body, "ParameterID", where), f"{where}.ParameterID")
                    if pid not in CONTROLS:
                        ignored.add(f"ParameterID {pid}")
                        continue
                    lo, hi, _ = CONTROLS[pid]
                    t0 = value(body.get("Time"), f"{where}.Time", 0.0, 1e6, 0.0)
                    if kind == "Parameter":
                        controls[pid].append((t0, np.array([0.0]), np.array([value(
                            r.key(body, "ParameterValue", where), f"{where}.ParameterValue", lo, hi, 0.0)])))
                        continue
                    pts = r.array(r.key(body, "ParameterCurveControlPoints", where), f"{where}.ParameterCurveControlPoints")
                    ts, vs = [], []
                    for j, p in enumerate(pts):
                        pw = f"{where}.ParameterCurveControlPoints[{j}]"
                        ts.append(value(r.key(p, "Time", pw, required=False), f"{pw}.Time", 0.0, 1e6, 0.0))
                        vs.append(value(r.key(p, "ParameterValue", pw), f"{pw}.ParameterValue", lo, hi, 0.0))
                    if ts:
                        order = np.argsort(ts, kind="stable")
                        controls[pid].append((t0, np.asarray(ts)[order], np.asarray(vs)[order]))
                else:
                    ignored.add(str(kind))
        if not continuous and not transients:
            r.fail("$.Pattern", "no haptic event to play" + (f" ({audio} audio event(s) only)" if audio else ""),
                   "a pattern needs at least one haptic event")
        burst = max(device.emphasis_min.duration_ms, device.emphasis_max.duration_ms) / 1000
        end = max([t + d for t, d, _ in continuous] + [t + burst for t, _ in transients] + [1.0 / rate_hz])
        n = grid_size(end, rate_hz, source)
        grid = np.arange(n) / rate_hz
        gain = _control(controls["HapticIntensityControl"], grid, 1.0)
        shift = _control(controls["HapticSharpnessControl"], grid, 0.0)
        amplitude = np.zeros(n)
        sharp = np.full(n, DEFAULTS["HapticSharpness"])
        loudest = np.zeros(n)
        for t, d, p in continuous:
            on = (grid >= t) & (grid <= t + d)
            ramp = np.ones(n)
            if p.get("AttackTime"):
                ramp = np.minimum(ramp, np.clip((grid - t) / p["AttackTime"], 0, 1))
            if p.get("ReleaseTime"):
                ramp = np.minimum(ramp, np.clip((t + d - grid) / p["ReleaseTime"], 0, 1))
            level = np.where(on, p.get("HapticIntensity", 1.0) * gain * ramp, 0.0)
            amplitude += level ** 2
            louder = level > loudest
            sharp[louder] = p.get("HapticSharpness", DEFAULTS["HapticSharpness"])
            loudest = np.maximum(loudest, level)
        frequency = np.clip(sharp + shift, 0.0, 1.0) ** 2
        emphasis = []
        for t, p in transients:
            g = float(_control(controls["HapticIntensityControl"], np.array([t]), 1.0)[0])
            s = float(_control(controls["HapticSharpnessControl"], np.array([t]), 0.0)[0])
            emphasis.append(Emphasis(t, min(1.0, (p.get("HapticIntensity", 1.0) * g) ** 2),
                                     float(np.clip(p.get("HapticSharpness", DEFAULTS["HapticSharpness"]) + s, 0, 1)) ** 2))
        notes = []
        if audio:
            notes.append(f"{source}: {audio} audio event(s) (AudioCustom/AudioContinuous) are sound, not haptics: left out")
        if clamped:
            notes.append(f"{source}: {len(clamped)} value(s) out of range were clamped, as Core Haptics does "
                         f"(first: {clamped[0]})")
        if envelope_only:
            notes.append(f"{source}: {', '.join(sorted(envelope_only))} not rendered")
        if ignored:
            notes.append(f"{source}: ignored, as Core Haptics ignores unsupported keys: {', '.join(sorted(ignored))}")
        return Curves(rate_hz, np.minimum(amplitude, 1.0), frequency, tuple(sorted(emphasis, key=lambda e: e.time_s))), notes


def _spans(total: float, gaps: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The parts of 0-``total`` outside ``gaps`` (0-``total`` itself where there are none)."""
    spans, start = [], 0.0
    for lo, hi in sorted(gaps):
        if lo > start:
            spans.append((start, lo))
        start = max(start, hi)
    if start < total or not gaps:
        spans.append((start, max(total, start)))
    return spans


def _name(r: Reader, node: Any, where: str) -> str:
    if not isinstance(node, str):
        r.fail(where, f"expected a string, got {type(node).__name__}", "types")
    return node


def _control(entries: list, grid: np.ndarray, default: float) -> np.ndarray:
    """A dynamic parameter over ``grid``: each curve or parameter holds from its start until a later one starts."""
    out = np.full(len(grid), default)
    for t0, ts, vs in sorted(entries, key=lambda e: e[0]):
        on = grid >= t0
        out[on] = np.interp(grid[on] - t0, ts, vs)
    return out
