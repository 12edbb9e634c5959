"""An effect whose model is a haptic file: ``model: {type: haptic-file, file: gear.haptic}``.

The file is read, validated and rendered once, when the effect loads (by its format's
documented synthesis); each impact then plays that signal, as a fraction of the
actuator's full range, through the effect's shaping and safety limiter like any model.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..errors import EffectError
from ..interfaces import Impact, Model
from ..params import BuildContext, doc
from ..signal import Signal
from .device import DEFAULT_DEVICE, device_named


class HapticFileModel(Model):
    """Plays a platform haptic file (``.haptic``, ``.ahap``, ``.android.json``, ``.ogg``, ``.hjif`` or a plugin's).

    With ``reference_velocity_mps`` the file plays at full strength for an impact at that
    velocity and scales linearly below it (never above full strength); without it every
    impact plays the file as written.
    """

    name = "haptic-file"
    units = "fraction"

    @dataclass(frozen=True)
    class Params:
        file: str = field(metadata=doc("the haptic file, relative to the effect file"))
        device: str = field(default=DEFAULT_DEVICE, metadata=doc("actuator configuration that maps 0-1 frequency "
                                                                 "to Hz: quest, console-pcm or an .acf file"))
        rate_hz: float = field(default=8000.0, metadata=doc("rate the file is rendered at (Hz)", min=1000.0, max=192000.0))
        reference_velocity_mps: float | None = field(default=None, metadata=doc(
            "impact velocity that plays the file at full strength (m/s); slower impacts scale down", min=1e-3, max=100.0))

    def __init__(self, params: Params, context: BuildContext):
        from . import format_for

        self.params = params
        path = Path(params.file).expanduser()
        self.path = path if path.is_absolute() else context.base_dir / path
        fmt = format_for(self.path)
        if fmt is None:
            from . import all_formats

            known = ", ".join(s for f in all_formats() for s in f.suffixes)
            raise EffectError(f"{self.path.name}: not a haptic file this install reads ({known})",
                              source=context.source, key="model.file")
        self.format = fmt
        self.device = device_named(params.device, base_dir=context.base_dir)
        self.decoded = fmt.read(self.path, self.device, rate_hz=params.rate_hz)

    @property
    def plays_as_recorded(self) -> bool:
        """Whether every velocity renders the file as it is (no ``reference_velocity_mps``)."""
        return self.params.reference_velocity_mps is None

    def render(self, impact: Impact) -> Signal:
        signal = self.decoded.signal
        if self.params.reference_velocity_mps is None:
            return signal
        return Signal(signal.samples * min(1.0, impact.velocity / self.params.reference_velocity_mps), signal.rate_hz)

    def notes(self, impact: Impact) -> list[str]:
        return list(self.decoded.notes)

    def describe(self) -> dict:
        return {"model": self.name, "file": str(self.path), "format": self.format.name, "device": self.device.name,
                "duration_s": self.decoded.signal.duration_s}
