"""Meta's ``.haptic`` 1.0 (meta-haptics-sdk resources/haptic-file-spec.md): write it strictly, read it as the runtime does.

Holds an amplitude envelope (0-1), emphasis points and a frequency envelope (0-1, mapped to
Hz by the device's ACF). Reading checks every validation rule of the spec; one rule is relaxed
as Meta's runtime relaxes it in its legacy-compatibility mode: frequency breakpoints after the
end of the amplitude envelope (as files written by Lofelt Studio have) are accepted with a
one-line warning and ignored past the end. ``hapticfx validate`` is strict.

Writing keeps the envelope at 0 from an emphasis point until the first millisecond at or after
its burst ends on the export device (a burst plays over the continuous signal ducked, not
silenced) and clips and rounds down every amplitude to the impact's peak, as ``.hjif`` does:
read back on that device, the file stays within the limited impact (tests/test_formats.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import __version__
from .base import ExportOptions
from .device import Device
from .document import Reader
from .envelope_format import EnvelopeFormat
from .pattern import MILLISECONDS, Curves, Emphasis, Pattern, written

RULES = ".haptic 1.0"


def _r(x: float) -> float:
    return round(float(x), 6)


class HapticFormat(EnvelopeFormat):
    """Meta Haptics Studio / Meta Haptics SDK ``.haptic`` 1.0."""

    name = "haptic"
    suffixes = (".haptic",)
    holds = frozenset({"envelope", "frequency", "transients"})
    description = "Meta .haptic 1.0 (Quest controllers, Meta Haptics SDK)"

    def __init__(self, *, strict: bool = False):
        self.strict = strict  # refuse legacy files too (Meta's strict validation mode)

    def document(self, pattern: Pattern, options: ExportOptions) -> Any:
        emphasis = {round(e.time_s, 6): e for e in pattern.emphasis}
        # The burst plays for as long as the 0-1 frequency written says; the envelope stays 0 until it has ended.
        times, values = pattern.continuous([(e.time_s, e.end_s(options.device, _r(e.frequency)))
                                            for e in pattern.emphasis], MILLISECONDS)
        amplitude = []
        for t, a in zip(times, values):
            point = {"time": _r(t), "amplitude": written(a)}
            e = emphasis.get(round(float(t), 6))
            if e is not None:
                point["emphasis"] = {"amplitude": written(max(min(e.amplitude, pattern.peak), a)),
                                     "frequency": _r(e.frequency)}
            amplitude.append(point)
        end = float(pattern.amplitude[-1, 0])
        frequency = [{"time": _r(min(t, end)), "frequency": _r(min(max(f, 0.0), 1.0))} for t, f in pattern.frequency]
        return {
            "version": {"major": 1, "minor": 0, "patch": 0},
            "metadata": {"editor": f"hapticfx {__version__}", "source": options.source,
                         "description": options.description, "tags": ["hapticfx", f"device:{options.device.name}"]},
            "signals": {"continuous": {"envelopes": {"amplitude": amplitude, "frequency": frequency}}},
        }

    def pattern(self, doc: Any, source: str) -> tuple[Pattern, list[str]]:
        """The validated :class:`Pattern` of a parsed ``.haptic`` document, and warnings."""
        r = Reader(source, RULES)
        notes: list[str] = []
        version = r.key(doc, "version", "$")
        major = r.number(r.key(version, "major", "$.version"), "$.version.major", integer=True)
        for part in ("minor", "patch"):
            r.number(r.key(version, part, "$.version"), f"$.version.{part}", integer=True)
        if major != 1:
            r.fail("$.version.major", f"version {major} is not supported; this reader follows 1.x", "version")
        signals = r.key(doc, "signals", "$")
        continuous = r.key(signals, "continuous", "$.signals")
        envelopes = r.key(continuous, "envelopes", "$.signals.continuous")
        where = "$.signals.continuous.envelopes"
        amp = r.array(r.key(envelopes, "amplitude", where), f"{where}.amplitude")
        times, values, emphasis = [], [], []
        last = None
        for i, point in enumerate(amp):
            at = f"{where}.amplitude[{i}]"
            t = r.number(r.key(point, "time", at), f"{at}.time")
            if t < 0:
                r.fail(f"{at}.time", f"time {t:g} is negative", "time >= 0")
            a = r.ranged(r.key(point, "amplitude", at), f"{at}.amplitude", 0.0, 1.0, "amplitude within 0.0-1.0")
            if last is not None and t < last:
                r.fail(f"{at}.time", f"time {t:g} comes before the previous breakpoint's {last:g}",
                       "breakpoints in non-decreasing time order")
            last = t
            e = r.key(point, "emphasis", at, required=False)
            if e is not None:
                ea = r.ranged(r.key(e, "amplitude", f"{at}.emphasis"), f"{at}.emphasis.amplitude", 0.0, 1.0,
                              "emphasis amplitude within 0.0-1.0")
                ef = r.ranged(r.key(e, "frequency", f"{at}.emphasis"), f"{at}.emphasis.frequency", 0.0, 1.0,
                              "emphasis frequency within 0.0-1.0")
                if ea < a:
                    r.fail(f"{at}.emphasis.amplitude", f"emphasis amplitude {ea:g} is below the envelope's {a:g}",
                           "emphasis amplitude >= the envelope amplitude at that point")
                emphasis.append(Emphasis(t, ea, ef))
            times.append(t)
            values.append(a)
        if len(times) < 2:
            r.fail(f"{where}.amplitude", f"{len(times)} amplitude breakpoint(s)", "at least two amplitude breakpoints")
        if times[-1] - times[0] <= 0:
            r.fail(f"{where}.amplitude", "the amplitude envelope has zero duration", "duration > 0")
        freq = r.key(envelopes, "frequency", where, required=False, default=[])
        freq = [] if freq is None else r.array(freq, f"{where}.frequency")
        ftimes, fvalues = [], []
        last = None
        beyond = 0
        for i, point in enumerate(freq):
            at = f"{where}.frequency[{i}]"
            t = r.number(r.key(point, "time", at), f"{at}.time")
            f = r.ranged(r.key(point, "frequency", at), f"{at}.frequency", 0.0, 1.0, "frequency within 0.0-1.0")
            if last is not None and t < last:
                r.fail(f"{at}.time", f"time {t:g} comes before the previous breakpoint's {last:g}",
                       "breakpoints in non-decreasing time order")
            last = t
            if not times[0] <= t <= times[-1]:
                if self.strict:
                    r.fail(f"{at}.time", f"frequency breakpoint at {t:g} s is outside the amplitude envelope "
                           f"({times[0]:g}-{times[-1]:g} s)", "no frequency breakpoint after the amplitude envelope")
                beyond += 1
            ftimes.append(t)
            fvalues.append(f)
        if beyond:
            notes.append(f"{source}: {beyond} frequency breakpoint(s) lie outside the amplitude envelope (a legacy "
                         "file, e.g. from Lofelt Studio); played in Meta's legacy-compatibility mode, ignored past its end")
        return Pattern(np.column_stack((times, values)), np.column_stack((ftimes, fvalues)).reshape(-1, 2),
                       tuple(emphasis)), notes

    def curves(self, doc: Any, source: str, device: Device, rate_hz: float) -> tuple[Curves, list[str]]:
        pattern, notes = self.pattern(doc, source)
        return pattern.curves(rate_hz, source), notes
