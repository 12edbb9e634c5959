"""Actuators with no hardware: a WAV file, and memory.

Either can stand in for another actuator (``--device wav:PATH``): it then
takes that actuator's spec, so the output has the rate, band and limits the
real device would get.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..atomic import user_path
from ..errors import DeviceError, HapticfxError
from ..interfaces import Actuator, ActuatorSpec
from ..params import BuildContext, doc
from ..signal import Signal
from .files import DEFAULT_WAV_FORMAT, WavWriter, check_overwrite


def _plain_spec(rate_hz: float) -> ActuatorSpec:
    return ActuatorSpec(rate_hz=rate_hz, volts_peak=1.0, band_hz=(0.0, rate_hz / 2))


@dataclass(frozen=True)
class _MemoryParams:
    rate_hz: float = field(default=48000.0, metadata=doc("output sample rate (Hz)", min=100.0, max=384000.0))
    keep_mib: float = field(default=16.0, metadata=doc(
        "most recent signals kept, in MiB; older ones are let go (counted in `released`)", min=0.0, max=65536.0))


class MemoryActuator(Actuator):
    """Keeps the signals it is given, newest last (``played``), up to ``keep_mib``; for tests and embedding.

    Every signal counts as played (``received``); to keep memory bounded on a
    long run the oldest are let go once the kept ones exceed ``keep_mib``
    (``released`` counts them).
    """

    name = "memory"
    Params = _MemoryParams

    def __init__(self, params: _MemoryParams = _MemoryParams(), context: BuildContext = BuildContext(), *,
                 spec: ActuatorSpec | None = None):
        self.spec = spec or _plain_spec(params.rate_hz)
        self.limits = self.spec.limits
        self.budget_bytes = int(params.keep_mib * 2**20)
        self.played: deque[Signal] = deque()
        self.received = 0
        self.released = 0
        self._bytes = 0
        self._lock = threading.Lock()

    def play(self, signal: Signal) -> None:
        with self._lock:
            self.received += 1
            self.played.append(signal)
            self._bytes += signal.samples.nbytes
            while self._bytes > self.budget_bytes and self.played:
                self._bytes -= self.played.popleft().samples.nbytes
                self.released += 1

    def describe(self) -> str:
        return "memory"


class WavActuator(Actuator):
    """Writes everything played to one WAV file (24-bit PCM by default), streamed, moved into place on close.

    Impacts played one after another are written back to back as they come, so
    memory stays bounded and a write failure is raised at once; the file appears
    whole at ``close()`` or not at all. An existing file that hapticfx did not
    write is kept unless ``overwrite`` is set.
    """

    name = "wav"

    @dataclass(frozen=True)
    class Params:
        path: str | None = field(default=None, metadata=doc("output file; default: the device given on the command line"))
        rate_hz: float = field(default=48000.0, metadata=doc("output sample rate (Hz)", min=100.0, max=384000.0))
        format: Literal["pcm16", "pcm24", "float32"] = field(
            default=DEFAULT_WAV_FORMAT, metadata=doc("sample format: 16- or 24-bit PCM (read by every tool), or float"))
        overwrite: bool = field(default=False, metadata=doc("replace an existing file that hapticfx did not write"))

    def __init__(self, params: "WavActuator.Params" = Params(), context: BuildContext = BuildContext(), *, spec: ActuatorSpec | None = None):
        target = params.path or (context.device if isinstance(context.device, str) else None)
        if not target:
            raise DeviceError("the wav actuator needs a path (actuator.path, or --device wav:PATH)")
        path = user_path(target)
        self.path = path if path.is_absolute() else context.base_dir / path if params.path else path
        self.params = params
        self.spec = spec or _plain_spec(params.rate_hz)
        self.limits = self.spec.limits
        self._writer: WavWriter | None = None
        self._failed: DeviceError | None = None
        self._lock = threading.Lock()

    def open(self) -> None:
        if not self.path.parent.exists():
            raise DeviceError(f"{self.path}: directory {self.path.parent} does not exist")
        try:
            check_overwrite(self.path, force=self.params.overwrite, option="actuator.overwrite: true")
        except HapticfxError as exc:
            raise DeviceError(str(exc)) from None

    def play(self, signal: Signal) -> None:
        if abs(signal.rate_hz - self.spec.rate_hz) > 1e-6:
            raise DeviceError(f"wav actuator runs at {self.spec.rate_hz} Hz, got a signal at {signal.rate_hz} Hz")
        block = np.atleast_2d(signal.samples)
        with self._lock:
            if self._failed is not None:
                raise self._failed  # the file is gone: every later impact fails the same way
            try:
                if self._writer is None:
                    self._writer = WavWriter(self.path, self.spec.rate_hz, block.shape[0], fmt=self.params.format)
                self._writer.write(block)
            except DeviceError as exc:
                self._failed, self._writer = exc, None
                raise

    def close(self) -> None:
        with self._lock:
            writer, self._writer = self._writer, None
            if self._failed is not None:
                raise DeviceError(f"{self.path}: not written ({self._failed})")
            if writer is not None:
                writer.close()

    def describe(self) -> str:
        return f"WAV file {self.path}"
