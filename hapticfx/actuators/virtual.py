"""Actuators with no hardware: a WAV file, and memory.

Either can stand in for another actuator (``--device wav:PATH``): it then
takes that actuator's spec, so the output has the rate, band and limits the
real device would get.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DeviceError
from ..interfaces import Actuator, ActuatorSpec
from ..params import BuildContext, doc
from ..signal import Signal
from .files import write_wav


def _plain_spec(rate_hz: float) -> ActuatorSpec:
    return ActuatorSpec(rate_hz=rate_hz, volts_peak=1.0, band_hz=(0.0, rate_hz / 2))


@dataclass(frozen=True)
class _RateParams:
    rate_hz: float = field(default=48000.0, metadata=doc("output sample rate (Hz)", min=100.0, max=384000.0))


class MemoryActuator(Actuator):
    """Keeps every signal it is given, in order (``played``); for tests and embedding."""

    name = "memory"
    Params = _RateParams

    def __init__(self, params: _RateParams = _RateParams(), context: BuildContext = BuildContext(), *, spec: ActuatorSpec | None = None):
        self.spec = spec or _plain_spec(params.rate_hz)
        self.limits = self.spec.limits
        self.played: list[Signal] = []
        self._lock = threading.Lock()

    def play(self, signal: Signal) -> None:
        with self._lock:
            self.played.append(signal)

    def describe(self) -> str:
        return "memory"


class WavActuator(Actuator):
    """Writes everything played to one WAV file, atomically, when closed.

    Impacts played one after another are written back to back; nothing is
    written if the program stops before ``close()``.
    """

    name = "wav"

    @dataclass(frozen=True)
    class Params:
        path: str | None = field(default=None, metadata=doc("output file; default: the device given on the command line"))
        rate_hz: float = field(default=48000.0, metadata=doc("output sample rate (Hz)", min=100.0, max=384000.0))

    def __init__(self, params: "WavActuator.Params" = Params(), context: BuildContext = BuildContext(), *, spec: ActuatorSpec | None = None):
        target = params.path or (context.device if isinstance(context.device, str) else None)
        if not target:
            raise DeviceError("the wav actuator needs a path (actuator.path, or --device wav:PATH)")
        path = Path(target).expanduser()
        self.path = path if path.is_absolute() else context.base_dir / path if params.path else path
        self.spec = spec or _plain_spec(params.rate_hz)
        self.limits = self.spec.limits
        self._chunks: list[np.ndarray] = []
        self._lock = threading.Lock()

    def open(self) -> None:
        if not self.path.parent.exists():
            raise DeviceError(f"{self.path}: directory {self.path.parent} does not exist")

    def play(self, signal: Signal) -> None:
        if abs(signal.rate_hz - self.spec.rate_hz) > 1e-6:
            raise DeviceError(f"wav actuator runs at {self.spec.rate_hz} Hz, got a signal at {signal.rate_hz} Hz")
        with self._lock:
            self._chunks.append(np.atleast_2d(signal.samples))

    def close(self) -> None:
        with self._lock:
            if self._chunks:
                write_wav(self.path, np.concatenate(self._chunks, axis=-1), self.spec.rate_hz)
                self._chunks = []

    def describe(self) -> str:
        return f"WAV file {self.path}"
