"""The ``csv-logger`` actuator: one CSV row per impact it is given.

Useful to tune an effect or record what a scene would have sent to a real
actuator: each row has the impact's index, when it was played (seconds since
open), the rate, its peak, RMS and time above half the peak, and the samples
themselves (space-separated, exact), so a row can be loaded back bit for bit.
The file appears complete and at once on ``close()`` (written to a temporary
file in the same directory, then renamed); an interrupted run leaves no half file.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hapticfx.errors import DeviceError
from hapticfx.interfaces import Actuator, ActuatorSpec, SafetyLimits
from hapticfx.params import BuildContext
from hapticfx.signal import Signal

COLUMNS = ("impact", "at_s", "channel", "rate_hz", "n_samples", "peak", "rms", "above_half_s", "samples")


class CsvLogger(Actuator):
    """Logs every signal it plays to a CSV file (one row per impact and channel)."""

    name = "csv-logger"

    @dataclass(frozen=True)
    class Params:
        """Keys of the effect file's ``actuator:`` section for ``type: csv-logger``."""

        path: str = field(default="hapticfx-impacts.csv", metadata={
            "doc": "CSV file to write (relative to the effect file); the effect's device or --device overrides it"})
        rate_hz: float = field(default=1000.0, metadata={
            "min": 100.0, "max": 192_000.0, "doc": "the rate the pipeline renders for this actuator"})
        peak: float = field(default=1.0, metadata={
            "min": 0.01, "max": 1.0, "doc": "hard peak limit, as a fraction of full scale"})

    def __init__(self, params: Params = Params(), context: BuildContext = BuildContext()):
        # Constructing never touches the output: the pipeline builds actuators just to read their spec.
        if isinstance(context.device, str):
            self.path = Path(context.device).expanduser()
        else:
            path = Path(params.path).expanduser()
            self.path = path if path.is_absolute() else Path(context.base_dir) / path
        self.spec = ActuatorSpec(
            rate_hz=params.rate_hz, volts_peak=1.0, band_hz=(0.0, params.rate_hz / 2),
            limits=SafetyLimits(peak=params.peak, rms=params.peak),
        )
        self.limits = self.spec.limits  # the pipeline replaces this with the effect's (lowered) limits
        self.rows = 0
        self._file = None
        self._writer = None
        self._impacts = 0
        self._t0 = 0.0

    def open(self) -> None:
        if self._file is not None:
            return
        directory = self.path.parent
        try:
            fd, self._tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".part", dir=directory)
        except OSError as exc:
            raise DeviceError(f"cannot write a CSV log in {directory}: {exc.strerror}", source=str(self.path)) from None
        self._file = os.fdopen(fd, "w", newline="", encoding="ascii")
        self._writer = csv.writer(self._file)
        self._writer.writerow(COLUMNS)
        self._impacts, self.rows, self._t0 = 0, 0, time.monotonic()

    def play(self, signal: Signal) -> None:
        if self._writer is None:
            raise DeviceError("csv-logger: play() before open()", source=str(self.path))
        at_s = time.monotonic() - self._t0
        for channel, samples in enumerate(np.atleast_2d(signal.samples)):
            peak = float(np.max(np.abs(samples)))
            above = int(np.count_nonzero(np.abs(samples) >= 0.5 * peak)) if peak > 0 else 0
            self._writer.writerow((
                self._impacts, f"{at_s:.6f}", channel, repr(signal.rate_hz), samples.size, repr(peak),
                repr(math.sqrt(float(np.mean(samples ** 2)))), repr(above / signal.rate_hz),
                " ".join(repr(float(v)) for v in samples),
            ))
            self.rows += 1
        self._impacts += 1

    def close(self) -> None:
        if self._file is None:
            return
        self._file.close()
        self._file = self._writer = None
        os.replace(self._tmp, self.path)

    def describe(self) -> str:
        return f"CSV log {self.path} ({self.rows} rows)" if self.rows else f"CSV log {self.path}"


def read_log(path: str | os.PathLike) -> list[dict]:
    """Read a csv-logger file back: one dict per row, ``samples`` as a float64 array."""
    with open(path, newline="", encoding="ascii") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        row["samples"] = np.array(row["samples"].split(), dtype=np.float64)
        for key in ("impact", "channel", "n_samples"):
            row[key] = int(row[key])
        for key in ("at_s", "rate_hz", "peak", "rms", "above_half_s"):
            row[key] = float(row[key])
    return rows
