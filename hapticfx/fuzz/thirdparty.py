"""Third-party actuators that step around the host (issue 31, case 6), registered at run time by the safety
probe and its tests: what they output is measured against the limits the host must still hold.

- ``lying-mixer`` declares ``limits_mix = True`` but limits nothing: it sums overlapping impacts by the time
  they were played, as a sound card's mixer would, into ``timeline``.
- ``rate-dropper`` asks for 48 kHz and agrees to 8 kHz in ``open()``; it plays impacts back to back into
  ``timeline`` (its own time).
- ``rate-shifter`` plays at 48 kHz and, after its first impact, reports 8 kHz (a device that re-negotiated).
- ``wav-remixer`` is the core's WAV actuator with its own ``play()``: it inherits the file's ``mix_probe`` (and
  its passing verdict) and sums impacts into ``timeline`` without the file's limiter.
- ``timeline-mixer`` declares ``limits_mix`` and ``takes_time`` and limits nothing: it sums impacts at the time
  the host gives each (the session's timeline, as a file output does), whenever they arrive.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import numpy as np

from ..actuators.virtual import WavActuator
from ..hookspecs import hookimpl
from ..interfaces import Actuator, ActuatorSpec, SafetyLimits
from ..params import BuildContext, doc
from ..signal import Signal

HARD = {"lying-mixer": SafetyLimits(peak=0.9, rms=0.7, source="actuator lying-mixer"),
        "rate-dropper": SafetyLimits(peak=1.0, rms=0.5, source="actuator rate-dropper"),
        "timeline-mixer": SafetyLimits(peak=0.9, rms=0.7, source="actuator timeline-mixer"),
        "rate-shifter": SafetyLimits(peak=1.0, rms=0.5, source="actuator rate-shifter")}


@dataclass(frozen=True)
class _Params:
    rate_hz: float = field(default=48000.0, metadata=doc("asked rate (Hz)", min=1000.0, max=192000.0))


class _Timeline(Actuator):
    """Keeps what it outputs on one timeline (``timeline()``)."""

    Params = _Params

    def __init__(self, params: _Params = _Params(), context: BuildContext = BuildContext()):
        self.spec = ActuatorSpec(rate_hz=params.rate_hz, volts_peak=1.0, band_hz=(0.0, params.rate_hz / 2),
                                 limits=HARD[self.name])
        self.limits = self.spec.limits
        self._out = np.zeros(0)
        self._lock = threading.Lock()

    def _add(self, start: int, x: np.ndarray) -> None:
        with self._lock:
            if self._out.size < start + x.size:
                self._out = np.concatenate([self._out, np.zeros(start + x.size - self._out.size)])
            self._out[start:start + x.size] += x

    def timeline(self) -> np.ndarray:
        with self._lock:
            return self._out.copy()


class LyingMixer(_Timeline):
    """Says it limits the sum of overlapping impacts; sums them by play time and limits nothing."""

    name = "lying-mixer"
    limits_mix = True

    def open(self) -> None:
        self._t0 = time.perf_counter()

    def play(self, signal: Signal) -> None:
        self._add(int((time.perf_counter() - self._t0) * self.spec.rate_hz), signal.samples.reshape(-1))


class RateDropper(_Timeline):
    """Agrees to a sixth of the asked rate in ``open()``; plays impacts back to back."""

    name = "rate-dropper"

    def open(self) -> None:
        self.spec = ActuatorSpec(rate_hz=self.spec.rate_hz / 6, volts_peak=1.0, band_hz=(0.0, self.spec.rate_hz / 12),
                                 limits=self.spec.limits)
        self._end = 0

    def play(self, signal: Signal) -> None:
        if signal.rate_hz != self.spec.rate_hz:  # the host must shape for the rate agreed in open()
            raise ValueError(f"rate-dropper runs at {self.spec.rate_hz:g} Hz, got {signal.rate_hz:g} Hz")
        x = signal.samples.reshape(-1)
        self._add(self._end, x)
        self._end += x.size


class RateShifter(_Timeline):
    """Opens at the asked rate; after its first impact its spec says a sixth of it."""

    name = "rate-shifter"

    def open(self) -> None:
        self._end = 0

    def play(self, signal: Signal) -> None:
        x = signal.samples.reshape(-1)
        self._add(self._end, x)
        self._end += x.size
        self.spec = ActuatorSpec(rate_hz=self.spec.rate_hz / 6, volts_peak=1.0, band_hz=(0.0, self.spec.rate_hz / 12),
                                 limits=self.spec.limits)


class TimelineMixer(_Timeline):
    """Says it limits its sum; sums impacts at the times it is given and limits nothing."""

    name = "timeline-mixer"
    limits_mix = True
    takes_time = True

    def play(self, signal: Signal, at_s: float | None = None) -> None:
        self._add(int(round((at_s or 0.0) * self.spec.rate_hz)), signal.samples.reshape(-1))


class WavRemixer(WavActuator):
    """The core's WAV actuator with a ``play()`` of its own, which sums and limits nothing."""

    name = "wav-remixer"

    def open(self) -> None:
        self._out, self._lock = np.zeros(0), threading.Lock()

    def play(self, signal: Signal, at_s: float | None = None) -> None:
        _Timeline._add(self, int(round((at_s or 0.0) * self.spec.rate_hz)), signal.samples.reshape(-1))

    def timeline(self) -> np.ndarray:
        return _Timeline.timeline(self)

    def close(self) -> None:
        pass


class ThirdParty:
    """The plugin that registers them (``pm.register(ThirdParty(), name=...)``)."""

    @hookimpl
    def register_actuators(self, register):
        register(LyingMixer.name, LyingMixer)
        register(RateDropper.name, RateDropper)
        register(TimelineMixer.name, TimelineMixer)
        register(WavRemixer.name, WavRemixer)
        register(RateShifter.name, RateShifter)
