"""The format interface: what a platform haptic file can hold, how to write one and how to read it back.

A :class:`Format` is the fifth kind of plugin (beside reducers, interpolators, models
and actuators), registered through ``register_formats``. It writes a rendered impact
(a :class:`~hapticfx.signal.Signal` normalised to the actuator's full range) to a file
and reads a file back into a signal that plays through the same shaping and safety
limiter as any model's output.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar, NamedTuple

from ..errors import HapticfxError
from ..signal import Signal

if TYPE_CHECKING:
    from .device import Device

HOLDS = ("waveform", "envelope", "frequency", "transients")  # what a format can hold, in words


class HapticFileError(HapticfxError):
    """A haptic file breaks a rule of its format: names the file, the JSON path and the rule."""


@dataclass(frozen=True)
class ExportOptions:
    """How an impact is turned into a platform file.

    ``device`` maps 0-1 frequency (and AHAP sharpness) to Hz; ``tolerance`` is the largest
    distance (fraction of full scale) of the amplitude envelope from its breakpoints;
    ``frequency_tolerance`` the same for the normalised frequency curve; ``transients`` whether
    a sharp onset becomes an emphasis point (a transient event).
    """

    device: "Device"
    tolerance: float = 0.01
    frequency_tolerance: float = 0.02
    transients: bool = True
    description: str = ""
    source: str = ""


class Decoded(NamedTuple):
    """A file read back: the signal it describes (fraction of full scale) and what a user should know."""

    signal: Signal
    notes: tuple[str, ...] = ()


class Format(abc.ABC):
    """A platform haptic file format.

    ``name`` is what ``hapticfx export --format`` takes; ``suffixes`` the file name
    endings it reads (lower case, with the dot); ``holds`` what of an impact the file
    can carry (a subset of :data:`HOLDS`).
    """

    name: ClassVar[str]
    suffixes: ClassVar[tuple[str, ...]]
    holds: ClassVar[frozenset[str]]
    description: ClassVar[str] = ""

    @abc.abstractmethod
    def write(self, path: Path, signal: Signal, options: ExportOptions) -> None:
        """Write ``signal`` (normalised to full scale, |x| <= 1) to ``path``, whole or not at all."""

    @abc.abstractmethod
    def read(self, path: Path, device: "Device", *, rate_hz: float) -> Decoded:
        """Read and validate ``path``; render what it describes at ``rate_hz``.

        Raises :class:`HapticFileError` for a file no runtime of the platform accepts.
        """


def suffix_of(path: Path, formats) -> "Format | None":
    """The format among ``formats`` whose longest suffix ends ``path``'s name, or None."""
    name = Path(path).name.lower()
    best, length = None, 0
    for fmt in formats:
        for suffix in fmt.suffixes:
            if name.endswith(suffix) and len(suffix) > length:
                best, length = fmt, len(suffix)
    return best
