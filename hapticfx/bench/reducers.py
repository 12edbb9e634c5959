"""``hapticfx bench reducers``: the paper's Table 4 analogue and reducer timings."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..timing import Timing
from ..processing import metrics

if TYPE_CHECKING:  # processing never imports the dataset package: the dependency runs the other way
    from ..data.dataset import Dataset

METRICS = (
    ("spectral", metrics.spectral_match),
    ("spectral (Welch)", metrics.welch_spectral_match),
    ("temporal", metrics.temporal_match),
    ("peak", lambda x, xyz, rate_hz: metrics.peak_match(x, xyz)),
)


@dataclass
class ObjectScores:
    """Mean (and standard deviation) of each metric over all drops of one object, per reducer."""

    object: str
    n_drops: int
    mean: dict[tuple[str, str], float]
    std: dict[tuple[str, str], float]


def score(ds: Dataset, reducers: dict, *, progress=None) -> list[ObjectScores]:
    """Every metric for every reducer over every drop of every object."""
    out = []
    for obj in ds.objects:
        if progress:
            progress(f"scoring {obj}")
        _, windows = ds.windows(obj)
        xyz = windows.reshape(-1, *windows.shape[-2:])
        mean, std = {}, {}
        for rname, reducer in reducers.items():
            x = reducer.reduce(xyz)
            for mname, fn in METRICS:
                values = fn(x, xyz, rate_hz=ds.rate_hz)
                mean[rname, mname], std[rname, mname] = float(np.mean(values)), float(np.std(values))
        out.append(ObjectScores(obj, xyz.shape[0], mean, std))
    return out


def time_reducers(reducers: dict, signal: np.ndarray, *, n_big: int, repeat: int, number: int) -> dict:
    """Per-call times of each reducer on one ``(N, 3)`` signal and on ``n_big`` 3-axis samples.

    Reducers are timed in alternation so that they share the machine's load.
    Returns ``{(reducer, "one" | "big"): Timing}``.
    """
    n = signal.shape[0]
    big = np.tile(signal, (max(1, n_big // n), 1, 1))
    times: dict = {(r, k): [] for r in reducers for k in ("one", "big")}
    for r in reducers.values():
        r.reduce(signal), r.reduce(big)
    for _ in range(repeat):
        for rname, r in reducers.items():
            t0 = time.perf_counter()
            for _ in range(number):
                r.reduce(signal)
            times[rname, "one"].append((time.perf_counter() - t0) / number)
            t0 = time.perf_counter()
            r.reduce(big)
            times[rname, "big"].append(time.perf_counter() - t0)
    return {k: Timing(tuple(v)) for k, v in times.items()}
