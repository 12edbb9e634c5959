"""Writers for rendered signals: WAV and CSV, both atomic."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..errors import DeviceError


def write_wav(path: Path, samples: np.ndarray, rate_hz: float) -> Path:
    """Write normalised samples (time last; channels first if 2D) as 32-bit float WAV, atomically."""
    data = np.atleast_2d(np.asarray(samples, dtype="<f4"))
    if abs(rate_hz - round(rate_hz)) > 1e-6:
        raise DeviceError(f"{path}: WAV needs an integer sample rate, got {rate_hz}")
    channels, rate = data.shape[0], int(round(rate_hz))
    payload = np.ascontiguousarray(data.T).tobytes()
    fmt = struct.pack("<HHIIHH", 3, channels, rate, rate * channels * 4, channels * 4, 32)  # 3 = IEEE float
    header = b"RIFF" + struct.pack("<I", 4 + 8 + len(fmt) + 8 + len(payload)) + b"WAVE"
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(header + b"fmt " + struct.pack("<I", len(fmt)) + fmt + b"data" + struct.pack("<I", len(payload)))
            f.write(payload)
    return Path(path)


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    """Write named equal-length columns as CSV with a header row, atomically."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=np.float64) for n in names])
    with atomic_path(path) as tmp:
        np.savetxt(tmp, data, delimiter=",", header=",".join(names), comments="", fmt="%.9g")
    return Path(path)
