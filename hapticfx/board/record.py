"""Recording drops from the serial accelerometer board (``hapticfx data record``).

The host opens the port with pyserial, says HELLO, starts the stream and
watches the deviation of the acceleration vector from its resting value
(gravity, tracked by a slow moving average while idle). When it exceeds
``threshold_g`` a drop is captured: ``pre_trigger`` samples from before the
trigger and the rest up to ``n_samples``. Each drop goes to its own tidy CSV
file (the import format of :mod:`hapticfx.data.csv_import`), labelled with the
object and the impact velocity ``v = sqrt(2 g h)`` of the drop height ``h``.
Before arming again the signal must stay below the threshold for ``holdoff_s``.
"""

from __future__ import annotations

import math
import re
import time
from collections import deque
from pathlib import Path
from typing import Callable

import numpy as np

from ..atomic import atomic_path
from ..data.csv_import import COLUMNS
from ..errors import DeviceError, SignalError
from ..objects import valid_object_id
from ..signal import valid_number
from .protocol import BAUD, SEQ_MODULO, BoardInfo, parse_hello, parse_sample

STANDARD_GRAVITY = 9.80665


def impact_velocity(height_m: float) -> float:
    """Free-fall impact velocity ``sqrt(2 g h)`` in m/s for a drop height in metres."""
    h = valid_number(height_m, name="height_m", minimum=0.0, maximum=1000.0)
    return math.sqrt(2.0 * STANDARD_GRAVITY * h)


def _open(port: str, baud: int):
    try:
        import serial
    except ImportError:
        raise DeviceError("recording needs pyserial: pip install pyserial") from None

    try:
        return serial.Serial(port, baud, timeout=0.2)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise DeviceError(f"{port}: cannot open serial port ({exc})") from None


def _readline(ser, port: str, deadline: float) -> str:
    while time.monotonic() < deadline:
        raw = ser.readline()
        if raw:
            return raw.decode("ascii", "replace")
    raise DeviceError(f"{port}: board stopped answering")


def _handshake(ser, port: str, timeout_s: float) -> BoardInfo:
    ser.write(b"STOP\nHELLO\n")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        line = ser.readline().decode("ascii", "replace").strip()
        # Skip what a board that was still streaming sends before it answers.
        if not line or line.startswith("OK") or parse_sample(line) is not None:
            continue
        return parse_hello(line, port=port)
    raise DeviceError(f"{port}: no answer to HELLO within {timeout_s:g} s (is the accelerometer sketch running?)")


def _next_drop(out_dir: Path, stem: str) -> int:
    pattern = re.compile(re.escape(stem) + r"_d(\d+)\.csv$")
    taken = [int(m.group(1)) for p in out_dir.glob(f"{stem}_d*.csv") if (m := pattern.match(p.name))]
    return max(taken, default=-1) + 1


def write_drop_csv(file: Path, *, object_id: str, velocity_mps: float, drop: int, rate_hz: float, accel_g: np.ndarray) -> None:
    """Write one drop ``(N, 3)`` g as tidy CSV, atomically."""
    with atomic_path(file) as tmp, open(tmp, "w", newline="") as f:
        f.write(",".join(COLUMNS) + "\n")
        for i, (x, y, z) in enumerate(accel_g):
            f.write(f"{object_id},{velocity_mps!r},{drop},{i / rate_hz:.6f},{x:.6g},{y:.6g},{z:.6g}\n")


class _Trigger:
    """Resting-level tracker plus threshold trigger with pre-trigger samples and hold-off."""

    def __init__(self, *, threshold_g: float, pre_trigger: int, n_samples: int, holdoff: int, settle: int):
        self.threshold = threshold_g
        self.n_samples = n_samples
        self.pre = deque(maxlen=pre_trigger)
        self.holdoff = holdoff
        self.quiet = 0
        self.settle = settle
        self.rest: np.ndarray | None = None
        self.seen = 0
        self.capture: list[np.ndarray] | None = None

    def feed(self, g: np.ndarray) -> np.ndarray | None:
        """Take one sample; returns a finished capture ``(n_samples, 3)`` or None."""
        self.seen += 1
        if self.capture is not None:
            self.capture.append(g)
            if len(self.capture) == self.n_samples:
                done, self.capture, self.quiet = np.array(self.capture), None, 0
                self.pre.clear()
                return done
            return None
        if self.rest is None:
            self.rest = g.copy()
        deviation = float(np.linalg.norm(g - self.rest))
        armed = self.seen > self.settle and self.quiet >= self.holdoff
        if armed and deviation > self.threshold:
            self.capture = [*self.pre, g]
            return None
        self.quiet = self.quiet + 1 if deviation <= self.threshold else 0
        if deviation <= self.threshold:
            # A slow average (time constant ~ 100 samples) follows the resting gravity vector.
            self.rest += (g - self.rest) * (0.5 if self.seen <= self.settle else 0.01)
        self.pre.append(g)
        return None


def record_drops(port: str, *, object_id: str, height_m: float, drops: int, out_dir: Path,
                 threshold_g: float = 0.5, pre_trigger: int = 50, n_samples: int = 1000,
                 holdoff_s: float = 0.2, baud: int = BAUD, timeout_s: float = 30.0,
                 progress: Callable[[str], None] | None = None) -> list[Path]:
    """Record ``drops`` triggered drops from the board on ``port``; returns the CSV files written."""
    velocity = impact_velocity(height_m)
    if velocity == 0.0:  # `data import` refuses every line of a 0 m/s drop: after the session is recorded
        raise SignalError("height_m must be above 0 (the drop height in metres)")
    valid_number(threshold_g, name="threshold_g", minimum=1e-6)
    valid_number(timeout_s, name="timeout_s", minimum=1e-3)
    if not valid_object_id(object_id):  # it names the files: `../x` wrote outside --out-dir
        raise SignalError(f"object id {object_id!r} must be letters, digits, '-', '_' or '.', not starting with a "
                          "dot (it names the files and, imported, the dataset's object)")
    if drops < 1 or pre_trigger < 0 or n_samples <= pre_trigger + 1:
        raise SignalError(f"need drops >= 1 and n_samples > pre_trigger + 1, got drops={drops}, "
                          f"pre_trigger={pre_trigger}, n_samples={n_samples}")
    say = progress or (lambda message: None)
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise SignalError(f"{out_dir}: not a folder; give --out-dir a folder for the CSV files")
    stem = f"{object_id}_h{height_m:g}m"
    written: list[Path] = []
    ser = _open(port, baud)
    try:
        info = _handshake(ser, port, min(timeout_s, 5.0))
        say(f"{port}: {info.board} ({info.sensor}) at {info.rate_hz:g} Hz; v = {velocity:.3f} m/s from h = {height_m:g} m")
        trigger = _Trigger(threshold_g=threshold_g, pre_trigger=pre_trigger, n_samples=n_samples,
                           holdoff=int(holdoff_s * info.rate_hz), settle=int(0.05 * info.rate_hz))
        ser.write(b"START\n")
        last_seq = None
        deadline = time.monotonic() + timeout_s
        while len(written) < drops:
            if time.monotonic() > deadline:
                raise DeviceError(f"{port}: no impact above {threshold_g:g} g within {timeout_s:g} s "
                                  f"({len(written)} of {drops} drops recorded)")
            sample = parse_sample(_readline(ser, port, deadline + 1.0))
            if sample is None:
                continue
            seq, *counts = sample
            if last_seq is not None and seq != (last_seq + 1) % SEQ_MODULO:
                lost = (seq - last_seq - 1) % SEQ_MODULO
                if trigger.capture is not None:
                    raise DeviceError(f"{port}: {lost} sample(s) lost during drop {len(written)} "
                                      f"(sequence {last_seq} -> {seq}); lower the load on the host and record again")
                trigger.pre.clear()
            last_seq = seq
            done = trigger.feed(info.to_g(counts))
            if done is not None:
                out_dir.mkdir(parents=True, exist_ok=True)  # made with the first drop: a failed start leaves nothing
                n = _next_drop(out_dir, stem)
                file = out_dir / f"{stem}_d{n:02d}.csv"
                write_drop_csv(file, object_id=object_id, velocity_mps=velocity, drop=n,
                               rate_hz=info.rate_hz, accel_g=done)
                written.append(file)
                deadline = time.monotonic() + timeout_s
                peak = float(np.max(np.linalg.norm(done - trigger.rest, axis=1)))
                say(f"drop {len(written)}/{drops}: peak {peak:.2f} g -> {file}")
        ser.write(b"STOP\n")
    finally:
        ser.close()
    return written
