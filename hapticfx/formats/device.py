"""Actuator configurations: how 0-1 frequency and emphasis map to Hz, cycles and shapes on a device.

A ``.haptic`` file says frequency 0-1, not Hz; Meta's runtime maps it linearly onto the
``continuous.frequency_min``-``frequency_max`` range of an actuator configuration file
(ACF, JSON5; meta-haptics-sdk resources/acf/README.md), and renders an emphasis as a short
burst whose frequency, length and shape move from ``emphasis.frequency_min`` to
``frequency_max`` as its 0-1 frequency grows. The two presets hold the values of Meta's
published ACFs (MIT): ``quest`` (resources/acf/MetaQuest.acf, the default) and
``console-pcm`` (resources/acf/Generic-Console-PCM.acf, a wideband voice coil, 20-250 Hz).
Any other ACF file is read with ``--device FILE.acf``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import HapticfxError

SHAPES = ("sine", "square", "triangle", "saw")


@dataclass(frozen=True)
class EmphasisEnd:
    """One end (0 or 1) of the emphasis range: burst frequency, length and wave shape."""

    frequency_hz: float
    duration_ms: float
    shape: str


@dataclass(frozen=True)
class Device:
    """An actuator configuration (the fields of an ACF that rendering uses)."""

    name: str
    frequency_min_hz: float
    frequency_max_hz: float
    emphasis_min: EmphasisEnd
    emphasis_max: EmphasisEnd
    gain: float = 1.0
    emphasis_ducking: float = 0.5
    emphasis_gain: float = 1.0
    emphasis_fade_out: float = 0.0

    def hz(self, normalised):
        """0-1 frequency to Hz (linear, as Meta's continuous oscillator maps it)."""
        return self.frequency_min_hz + normalised * (self.frequency_max_hz - self.frequency_min_hz)

    def burst_hz(self, normalised: float) -> float:
        """The frequency (Hz) of the emphasis burst at 0-1 frequency ``normalised``, as Meta's renderer plays it."""
        return self.emphasis_min.frequency_hz + normalised * (self.emphasis_max.frequency_hz - self.emphasis_min.frequency_hz)

    def burst_ms(self, normalised: float) -> float:
        """The length (ms) of the emphasis burst at 0-1 frequency ``normalised``, as Meta's renderer plays it."""
        return self.emphasis_min.duration_ms + normalised * (self.emphasis_max.duration_ms - self.emphasis_min.duration_ms)

    def normalised(self, hz):
        """Hz to 0-1 frequency, clamped to the device's range (a point range maps to 0.5)."""
        import numpy as np

        span = self.frequency_max_hz - self.frequency_min_hz
        if span <= 0:
            return np.full_like(np.asarray(hz, dtype=float), 0.5)
        return np.clip((np.asarray(hz, dtype=float) - self.frequency_min_hz) / span, 0.0, 1.0)


PRESETS = {
    "quest": Device("quest", 55.0, 200.0, EmphasisEnd(55.0, 36.4, "sine"), EmphasisEnd(165.0, 12.1, "square"),
                    gain=1.0, emphasis_ducking=0.5),
    "console-pcm": Device("console-pcm", 20.0, 250.0, EmphasisEnd(55.0, 27.0, "sine"), EmphasisEnd(130.0, 20.0, "square"),
                          gain=1.0, emphasis_ducking=0.5),
}
DEFAULT_DEVICE = "quest"


def _number(doc, key: str, source: str, *, minimum: float = 0.0, maximum: float | None = None) -> float:
    node = doc
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            raise HapticfxError(f"required key {key!r} is missing", source=source, key="$." + key)
        node = node[part]
    if isinstance(node, bool) or not isinstance(node, (int, float)) or node != node:
        raise HapticfxError(f"expected a number, got {node!r}", source=source, key="$." + key)
    if node < minimum or (maximum is not None and node > maximum):
        raise HapticfxError(f"{node} is out of range {minimum}-{maximum if maximum is not None else 'inf'}",
                            source=source, key="$." + key)
    return float(node)


def _end(doc, which: str, source: str) -> EmphasisEnd:
    shape = doc.get("emphasis", {}).get(which, {}).get("shape") if isinstance(doc.get("emphasis"), dict) else None
    if shape not in SHAPES:
        raise HapticfxError(f"expected one of {', '.join(SHAPES)}, got {shape!r}", source=source,
                            key=f"$.emphasis.{which}.shape")
    return EmphasisEnd(_number(doc, f"emphasis.{which}.output_frequency", source, minimum=1e-3),
                       _number(doc, f"emphasis.{which}.duration_ms", source, minimum=1e-3), shape)


def read_acf(path: Path) -> Device:
    """An ACF file (JSON5) as a :class:`Device`; every error names the file and the key."""
    from .document import load_document

    source = str(path)
    doc = load_document(Path(path), lenient=True)
    if not isinstance(doc, dict):
        raise HapticfxError("an ACF is a JSON5 object", source=source, key="$")
    fmin = _number(doc, "continuous.frequency_min", source, minimum=1e-3)
    fmax = _number(doc, "continuous.frequency_max", source, minimum=fmin)
    return Device(Path(path).stem, fmin, fmax, _end(doc, "frequency_min", source), _end(doc, "frequency_max", source),
                  gain=_number(doc, "continuous.gain", source, maximum=1.0),
                  emphasis_ducking=_number(doc, "continuous.emphasis_ducking", source, maximum=1.0),
                  emphasis_gain=_number(doc, "emphasis.gain", source, maximum=1.0),
                  emphasis_fade_out=_number(doc, "emphasis.fade_out_percent", source, maximum=1.0))


def device_named(spec: str | None, *, base_dir: Path | None = None) -> Device:
    """A preset by name (``quest``, ``console-pcm``) or an ACF file path."""
    spec = spec or DEFAULT_DEVICE
    if spec in PRESETS:
        return PRESETS[spec]
    path = Path(spec).expanduser()
    if base_dir is not None and not path.is_absolute():
        path = base_dir / path
    if path.suffix.lower() != ".acf" and not path.exists():
        raise HapticfxError(f"unknown device {spec!r}; use one of {', '.join(PRESETS)} or an .acf file")
    return read_acf(path)
