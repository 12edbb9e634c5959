"""Toy drop recordings for tests and demos (not physics: damped sinusoids).

Each drop is gravity plus, from a jittered onset, three axes of decaying
sinusoids whose amplitude grows with velocity; drop-to-drop variation comes
from ``rng``. The physically simulated built-in dataset is
``builtin:helmet-drops`` (:mod:`hapticfx.droprig.synth`); this only exercises the pipeline.
"""

from __future__ import annotations

import numpy as np

from ..objects import ObjectInfo
from .build import ObjectRecordings


def toy_recordings(info: ObjectInfo, velocities, *, drops: int = 10, rate_hz: float = 1000.0,
                         duration_s: float = 1.0, seed: int = 0, noise_g: float = 0.005) -> ObjectRecordings:
    """``drops`` synthetic drops of ``info`` at each velocity, raw g with gravity on z."""
    rng = np.random.default_rng(seed)
    v = np.asarray(velocities, np.float64)
    n = int(round(duration_s * rate_hz))
    t = np.arange(n) / rate_hz
    acc = np.zeros((v.size, drops, n, 3))
    acc[..., 2] = 1.0
    freqs = np.array([90.0, 140.0, 210.0]) * (0.2 / info.mass_kg) ** 0.25
    for i, vel in enumerate(v):
        for d in range(drops):
            onset = 0.25 + rng.uniform(0.0, 0.05)
            tau = 0.03 * rng.uniform(0.8, 1.2)
            dt = np.clip(t - onset, 0.0, None)
            env = np.where(t >= onset, np.exp(-dt / tau), 0.0)
            amp = 0.8 * vel * rng.uniform(0.85, 1.15, 3) * np.array([1.0, 0.6, 0.35])
            phase = rng.uniform(0, 2 * np.pi, 3)
            acc[i, d] += amp * env[:, None] * np.sin(2 * np.pi * freqs * rng.uniform(0.95, 1.05) * dt[:, None] + phase)
    acc += rng.normal(0.0, noise_g, acc.shape)
    return ObjectRecordings(info, v, acc)
