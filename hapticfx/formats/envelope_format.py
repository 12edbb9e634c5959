"""What every parametric format shares: analyse a signal into a pattern, write a document, read one back and play it."""

from __future__ import annotations

import abc
from pathlib import Path
from typing import Any

from ..signal import Signal
from .analysis import analyse
from .base import Decoded, ExportOptions, Format
from .device import Device
from .document import load_document, write_document
from .pattern import Curves, Pattern
from .synthesis import synthesize


class EnvelopeFormat(Format):
    """A JSON format that holds a :class:`~hapticfx.formats.pattern.Pattern` (or something it renders to curves)."""

    lenient: bool = False  # parse JSON5 (AHAP) instead of strict JSON

    def write(self, path: Path, signal: Signal, options: ExportOptions) -> None:
        pattern = analyse(signal.samples, signal.rate_hz, options.device, tolerance=options.tolerance,
                          frequency_tolerance=options.frequency_tolerance, transients=options.transients and "transients" in self.holds)
        write_document(Path(path), self.document(pattern, options))

    def read(self, path: Path, device: Device, *, rate_hz: float) -> Decoded:
        doc = load_document(Path(path), lenient=self.lenient)
        curves, notes = self.curves(doc, str(path), device, rate_hz)
        return Decoded(Signal(synthesize(curves, device), rate_hz), tuple(notes))

    @abc.abstractmethod
    def document(self, pattern: Pattern, options: ExportOptions) -> Any:
        """The file's JSON document for ``pattern`` (it must pass every rule :meth:`curves` checks)."""

    @abc.abstractmethod
    def curves(self, doc: Any, source: str, device: Device, rate_hz: float) -> tuple[Curves, list[str]]:
        """Validate ``doc`` and sample what it describes at ``rate_hz``; returns the curves and notes."""
