"""A small synthetic dataset for the plugin's tests: damped sinusoids whose pitch and decay follow velocity."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hapticfx.data.dataset import DatasetWriter
from hapticfx.objects import PAPER_OBJECTS

PAPER_V = [2.42, 2.80, 3.13, 3.43, 3.70, 3.96, 4.20, 4.43, 4.65, 4.85, 5.05, 5.24]


def profile(v: float, n: int, rate: float, k: int) -> np.ndarray:
    t = np.arange(n) / rate
    f = 30.0 + 8.0 * k + 6.0 * v
    decay = 25.0 + 4.0 * v
    onset = 0.02
    env = np.where(t >= onset, np.exp(-decay * (t - onset)), 0.0)
    return 0.4 * v * (1 + 0.3 * k) * env * np.sin(2 * np.pi * f * (t - onset))


def write_synthetic(out: Path, *, n_samples: int = 100, objects=("plastic-frame", "steel-plate"),
                    name: str = "synthetic") -> Path:
    rate = 1000.0
    with DatasetWriter(out, name=name, rate_hz=rate, n_samples=n_samples) as w:
        for k, obj in enumerate(objects):
            w.add_object(PAPER_OBJECTS[obj])
            prof = np.stack([profile(v, n_samples, rate, k) for v in PAPER_V])
            w.write_bank("max-min", obj, PAPER_V, prof)
    return out
