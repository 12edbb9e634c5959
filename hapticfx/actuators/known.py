"""The first-party sound-card actuators as the core knows them: their specs, without their device code.

An effect for a vibro-transducer renders to a file (WAV, CSV, PNG, a platform haptic file) at that actuator's
rate, band and limits whether or not ``hapticfx-soundcard`` is installed; only playing on a sound card needs the
plugin. The plugin takes its actuators' specs from here, so there is one description of each.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import DeviceUnavailable
from ..interfaces import Actuator, ActuatorSpec, SafetyLimits
from ..signal import Signal


@dataclass(frozen=True)
class Known:
    """A first-party actuator's fixed description (paper Sect. 3.2) and the distribution that drives it."""

    distribution: str
    band_hz: tuple[float, float]
    volts_peak: float
    default_gain: float
    hard_limits: SafetyLimits
    rate_hz: float = 48000.0

    def spec(self, rate_hz: float | None = None) -> ActuatorSpec:
        return ActuatorSpec(rate_hz=float(self.rate_hz if rate_hz is None else rate_hz), volts_peak=self.volts_peak,
                            band_hz=self.band_hz, waveform=True, limits=self.hard_limits,
                            default_gain=self.default_gain)


KNOWN = {
    # Vibro-transducer Vp408: +-5 V input, 20-15,000 Hz response.
    "vibro-transducer": Known("hapticfx-soundcard", (20.0, 15000.0), 5.0, 0.8, SafetyLimits(peak=1.0, rms=0.7)),
    # Haptuator MM1C (Tactile Labs): +-5 V input, 30-800 Hz response.
    "haptuator": Known("hapticfx-soundcard", (30.0, 800.0), 5.0, 0.6, SafetyLimits(peak=1.0, rms=0.5)),
}


def spec_only(name: str) -> type[Actuator]:
    """An actuator class with ``name``'s spec that renders to files but cannot open a device."""
    known = KNOWN[name]

    class SpecOnly(Actuator):
        @dataclass(frozen=True)
        class Params:
            """No options: a sound card's own (latency, queue, ...) come with its plugin."""

        def __init__(self, params=None, context=None):
            self.spec = known.spec()
            self.limits = self.spec.limits

        def _missing(self) -> DeviceUnavailable:
            from ..registry import install_hint

            return DeviceUnavailable(f"{name} plays through {known.distribution}, which is not installed "
                                     f"({install_hint(known.distribution)})")

        def open(self) -> None:
            raise self._missing()

        def play(self, signal: Signal) -> None:
            raise self._missing()

    SpecOnly.name = name
    SpecOnly.__name__ = SpecOnly.__qualname__ = f"SpecOnly[{name}]"
    SpecOnly.__doc__ = f"The {name}'s spec, for rendering to files; playing it needs {known.distribution}."
    return SpecOnly


__all__ = ["KNOWN", "Known", "spec_only"]
