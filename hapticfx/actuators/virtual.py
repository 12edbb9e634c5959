"""Actuators with no hardware: a WAV or CSV file, and memory.

Either can stand in for another actuator (``--device wav:PATH``): it then
takes that actuator's spec, so the output has the rate, band and limits the
real device would get.
"""

from __future__ import annotations

import abc
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Literal

from ..atomic import check_writable, user_path
from ..errors import DeviceError, HapticfxError
from ..interfaces import Actuator, ActuatorSpec
from ..params import BuildContext, doc
from ..signal import Signal
from .files import DEFAULT_WAV_FORMAT, CsvWriter, WavWriter, check_overwrite
from ..safety import LimiterReport
from .timeline import Timeline, TimelineProbe


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


class _FileActuator(Actuator):
    """Writes a session to one file on its own timeline (:class:`~hapticfx.actuators.timeline.Timeline`).

    Each impact lies at its time (``play(signal, at_s=...)``, seconds into the
    file; an engine passes the impact's time since the session's first impact:
    the sender's when it gave one, else its arrival); an impact without a time
    follows the last one. Overlapping
    impacts sum, and the safety limiter runs on the sum in the file's own time,
    so the file holds its limits (peak, RMS over its window) sample for sample.
    The file is streamed to a temporary file, bounded by ``max_mib``, and moved
    into place whole at ``close()`` or not at all. An existing file that
    hapticfx did not write is kept unless ``overwrite`` is set.
    """

    limits_mix = True  # it sums what it is given and limits the sum itself
    takes_time = True
    overwrite_option = "actuator.overwrite: true"  # what a refusal to replace a file says to give

    @classmethod
    def mix_probe(cls, limits, rate_hz: float) -> TimelineProbe:
        """Its timeline's mixer and limiter without a file, for the host's conformance check."""
        return TimelineProbe(limits, rate_hz)

    def __init__(self, params, context: BuildContext = BuildContext(), *, spec: ActuatorSpec | None = None):
        target = params.path or (context.device if isinstance(context.device, str) else None)
        if not target:
            raise DeviceError(f"the {self.name} actuator needs a path (actuator.path, or --device {self.name}:PATH)")
        path = user_path(target)
        self.path = path if path.is_absolute() else context.base_dir / path if params.path else path
        self.params = params
        self.spec = spec or _plain_spec(params.rate_hz)
        self.limits = self.spec.limits
        self._timeline: Timeline | None = None
        self._closed_counts: dict[str, int] = {}
        self._closed_report: LimiterReport | None = None
        self._failed: DeviceError | None = None
        self._lock = threading.Lock()

    def output_key(self):
        """The file: scene entries and effects that name one path write one file, summed and limited as
        one (each writing its own would leave only the last at the path)."""
        return "file", str(self.path.resolve())

    @abc.abstractmethod
    def _writer(self, channels: int):
        """A new streamed file writer (:mod:`hapticfx.actuators.files`) for ``channels`` channels."""

    def open(self) -> None:
        if not self.path.parent.exists():
            raise DeviceError(f"{self.path}: directory {self.path.parent} does not exist")
        try:
            check_overwrite(self.path, force=self.params.overwrite, option=self.overwrite_option)
        except HapticfxError as exc:
            raise DeviceError(str(exc)) from None
        try:  # the file is made at the first impact: a folder it cannot be made in is said now, not then
            check_writable(self.path.parent)
        except OSError as exc:
            raise DeviceError(f"{self.path}: cannot write in {self.path.parent} ({exc.strerror})") from None

    def play(self, signal: Signal, at_s: float | None = None) -> None:
        """Place ``signal`` at ``at_s`` seconds into the file (None: right after the last impact)."""
        if abs(signal.rate_hz - self.spec.rate_hz) > 1e-6:
            raise DeviceError(f"{self.name} actuator runs at {self.spec.rate_hz} Hz, got a signal at {signal.rate_hz} Hz")
        with self._lock:
            if self._failed is not None:
                raise self._failed  # the file is gone: every later impact fails the same way
            try:
                if self._timeline is None:
                    self._timeline = Timeline(self._writer, self.spec.rate_hz, self.limits,
                                              max_bytes=int(self.params.max_mib * 2**20), name=str(self.path))
                self._timeline.place(signal.samples, at_s)
            except DeviceError as exc:
                self._failed, self._timeline = exc, None
                raise

    def close(self) -> None:
        with self._lock:
            timeline, self._timeline = self._timeline, None
            if self._failed is not None:
                raise DeviceError(f"{self.path}: not written ({self._failed})")
            if timeline is not None:
                timeline.close()
                self._closed_counts = {"placed_late": timeline.late, "cut_at_file_bound": timeline.cut}
                self._closed_report = timeline.limiter.report() if timeline.limiter is not None else None

    def limiter_report(self) -> LimiterReport:
        """What the file's limiter did to the sum so far (the whole file, once closed)."""
        with self._lock:
            t = self._timeline
            report = t.limiter.report() if t is not None and t.limiter is not None else self._closed_report
        return report if report is not None else LimiterReport()

    def losses(self) -> dict[str, int]:
        """Impacts moved later than their time (``placed_late``) or cut at the file's bound."""
        with self._lock:
            t = self._timeline
            counts = {"placed_late": t.late, "cut_at_file_bound": t.cut} if t else self._closed_counts
        return {k: v for k, v in counts.items() if v}


@dataclass(frozen=True)
class _FileParams:
    path: str | None = field(default=None, metadata=doc("output file; default: the device given on the command line"))
    rate_hz: float = field(default=48000.0, metadata=doc("output sample rate (Hz)", min=100.0, max=384000.0))
    max_mib: float = field(default=512.0, metadata=doc(
        "largest file (MiB); what a session would write beyond it is left out, and the log says so once",
        min=0.001, max=65536.0))
    overwrite: bool = field(default=False, metadata=doc("replace an existing file that hapticfx did not write"))


class WavActuator(_FileActuator):
    """Writes a session to one WAV file (24-bit PCM by default), each impact at its time, limited in the file's
    time (see :class:`_FileActuator`)."""

    name = "wav"

    @dataclass(frozen=True)
    class Params(_FileParams):
        format: Literal["pcm16", "pcm24", "float32"] = field(
            default=DEFAULT_WAV_FORMAT, metadata=doc("sample format: 16- or 24-bit PCM (read by every tool), or float"))

    def _writer(self, channels: int) -> WavWriter:
        return WavWriter(self.path, self.spec.rate_hz, channels, fmt=self.params.format)

    def describe(self) -> str:
        return f"WAV file {self.path}"


class CsvActuator(_FileActuator):
    """Writes a session to one CSV file (``t_s`` and a column per channel), each impact at its time, limited in
    the file's time (see :class:`_FileActuator`)."""

    name = "csv"
    Params = _FileParams

    def _writer(self, channels: int) -> CsvWriter:
        return CsvWriter(self.path, self.spec.rate_hz, channels)

    def describe(self) -> str:
        return f"CSV file {self.path}"
