"""The line protocol between the host and the accelerometer board (firmware sketch
``hapticfx/firmware/accelerometer/accelerometer.ino``).

ASCII lines at 500000 baud; the host ends its lines with ``\\n``, the board
with ``\\r\\n`` (Arduino ``Serial.println``); both sides ignore the ``\\r``.
The host speaks first (pyserial flushes input on open, so a banner sent
before would be lost)::

    host  -> HELLO
    board <- HAPTICFX-ACCEL 1 rate_hz=1000 sensor=ADXL335 board=GY-61 adc_bits=10 zero=512,512,512 counts_per_g=102.4,102.4,102.4
    host  -> START
    board <- OK START
    board <- 0,512,512,614          seq,x,y,z: raw ADC counts, seq counts modulo 65536
    board <- 1,511,513,615          ... one line per sample at rate_hz
    host  -> STOP
    board <- OK STOP                (sample lines sent before it may still arrive)

Any other command is answered ``ERR unknown command <text>``. Acceleration in g
is ``(count - zero) / counts_per_g`` per axis.
"""

from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np

from ..errors import DeviceError, one_line, preview

BAUD = 500000
MAGIC = "HAPTICFX-ACCEL"
VERSION = 1
SEQ_MODULO = 65536


@dataclass(frozen=True)
class BoardInfo:
    """What a board said in its HELLO reply."""

    rate_hz: float
    sensor: str
    board: str
    adc_bits: int
    zero: tuple[float, float, float]
    counts_per_g: tuple[float, float, float]

    def hello_line(self) -> str:
        trip = lambda v: ",".join(f"{x:g}" for x in v)  # noqa: E731
        return (f"{MAGIC} {VERSION} rate_hz={self.rate_hz:g} sensor={self.sensor} board={self.board} "
                f"adc_bits={self.adc_bits} zero={trip(self.zero)} counts_per_g={trip(self.counts_per_g)}")

    def to_g(self, counts: np.ndarray) -> np.ndarray:
        """Raw counts ``(..., 3)`` to g."""
        return (np.asarray(counts, np.float64) - np.asarray(self.zero)) / np.asarray(self.counts_per_g)

    def to_counts(self, g: np.ndarray) -> np.ndarray:
        """g ``(..., 3)`` to raw counts, rounded and clipped to the ADC's range."""
        counts = np.rint(np.asarray(g, np.float64) * np.asarray(self.counts_per_g) + np.asarray(self.zero))
        return np.clip(counts, 0, 2 ** self.adc_bits - 1).astype(np.int64)


GY61 = BoardInfo(1000.0, "ADXL335", "GY-61", 10, (512.0, 512.0, 512.0), (102.4, 102.4, 102.4))


def parse_hello(line: str, *, port: str = "board") -> BoardInfo:
    """Parse a HELLO reply; a wrong or incomplete one is a :class:`DeviceError`."""
    parts = line.strip().split()
    if len(parts) < 2 or parts[0] != MAGIC:
        raise DeviceError(f"{port}: not a hapticfx accelerometer board (answered {preview(line.strip())} to HELLO)")
    if parts[1] != str(VERSION):
        raise DeviceError(f"{port}: board speaks protocol version {preview(parts[1])}; this hapticfx speaks {VERSION}")
    fields = dict(p.split("=", 1) for p in parts[2:] if "=" in p)
    try:
        trip = lambda k: tuple(float(x) for x in fields[k].split(","))  # noqa: E731
        info = BoardInfo(float(fields["rate_hz"]), fields.get("sensor", "unknown"), fields.get("board", "unknown"),
                         int(fields["adc_bits"]), trip("zero"), trip("counts_per_g"))
    except (KeyError, ValueError) as exc:
        raise DeviceError(f"{port}: incomplete HELLO reply {preview(line.strip())} ({one_line(str(exc), 60)})") from None
    if len(info.zero) != 3 or len(info.counts_per_g) != 3:
        raise DeviceError(f"{port}: HELLO reply needs three zero and three counts_per_g values: {preview(line.strip())}")
    bits = 2 ** info.adc_bits if 1 <= info.adc_bits <= 32 else None
    checks = (
        ("rate_hz", info.rate_hz, 1.0 <= info.rate_hz <= 1e6, "1 to 1e6 Hz"),
        ("adc_bits", info.adc_bits, bits is not None, "1 to 32 bits"),
        ("zero", info.zero, bits is not None and all(math.isfinite(z) and 0 <= z <= bits for z in info.zero),
         "counts within the ADC's range"),
        ("counts_per_g", info.counts_per_g, all(math.isfinite(c) and 1e-6 <= c <= 1e9 for c in info.counts_per_g),
         "finite counts per g, 1e-6 to 1e9"),
    )
    for name, value, ok, expected in checks:
        if not ok:
            raise DeviceError(f"{port}: HELLO reply has {name}={preview(value)}; expected {expected}")
    return info


def parse_sample(line: str) -> tuple[int, int, int, int] | None:
    """``(seq, x, y, z)`` from a sample line, or None if the line is not one."""
    parts = line.strip().split(",")
    if len(parts) != 4:
        return None
    try:
        seq, x, y, z = (int(p) for p in parts)
    except ValueError:
        return None
    return seq, x, y, z


def sample_line(seq: int, counts) -> str:
    x, y, z = (int(c) for c in counts)
    return f"{seq % SEQ_MODULO},{x},{y},{z}\r\n"
