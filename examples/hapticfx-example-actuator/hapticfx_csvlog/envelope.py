"""A haptic file format: the amplitude envelope as ``time_s,amplitude`` lines (``NAME.env.csv``).

How a third party adds a format: subclass :class:`hapticfx.formats.Format`, say what the
file holds, write a rendered impact (a fraction of full scale) and read a file back into a
signal. hapticfx's own analysis and synthesis do the signal work; a broken file raises
:class:`~hapticfx.formats.HapticFileError` naming the file, the place and the rule.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hapticfx.atomic import atomic_path
from hapticfx.formats import Decoded, ExportOptions, Format, HapticFileError
from hapticfx.formats.analysis import analyse
from hapticfx.formats.pattern import Pattern
from hapticfx.formats.synthesis import synthesize
from hapticfx.signal import Signal


class EnvelopeCsv(Format):
    """Amplitude breakpoints, one ``time_s,amplitude`` line each; played at the device's middle frequency."""

    name = "envelope-csv"
    suffixes = (".env.csv",)
    holds = frozenset({"envelope"})
    description = "amplitude envelope as CSV (example plugin)"

    def write(self, path: Path, signal: Signal, options: ExportOptions) -> None:
        pattern = analyse(signal.samples, signal.rate_hz, options.device, tolerance=options.tolerance, transients=False)
        with atomic_path(path) as tmp:  # whole or not at all
            tmp.write_text("".join(f"{t:.4f},{a:.5f}\n" for t, a in pattern.amplitude))

    def read(self, path: Path, device, *, rate_hz: float) -> Decoded:
        rows = []
        for number, line in enumerate(Path(path).read_text().splitlines(), start=1):
            try:
                t, a = (float(v) for v in line.split(","))
            except ValueError:
                raise HapticFileError(f"line {number}: expected time_s,amplitude (envelope-csv: two numbers a line)",
                                      source=str(path)) from None
            if not 0.0 <= a <= 1.0 or (rows and t < rows[-1][0]):
                raise HapticFileError(f"line {number}: amplitude 0-1 and times in order (envelope-csv: values)",
                                      source=str(path))
            rows.append((t, a))
        if len(rows) < 2 or rows[-1][0] <= rows[0][0]:
            raise HapticFileError("at least two lines spanning a duration > 0 (envelope-csv: length)", source=str(path))
        pattern = Pattern(np.array(rows), np.zeros((0, 2)))
        return Decoded(Signal(synthesize(pattern.curves(rate_hz), device), rate_hz))
