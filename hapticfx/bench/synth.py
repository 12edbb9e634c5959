"""``hapticfx bench synth``: how much parallel simulation (joblib) speeds up ``data synth``.

Each run records the same drops of one built-in object (:func:`~hapticfx.droprig.synth.record_drops`,
same seed) serially and with each number of processes; the worker pool is started inside the timed
region (as ``data synth`` starts it). The table gives the median wall time of ``repeats`` runs with
its spread (min-max), the speed-up over the serial median of the same run, and whether the arrays
are identical to the serial ones.
"""

from __future__ import annotations

import statistics
import time
from typing import Callable

import numpy as np

from ..objects import PAPER_OBJECTS
from ..droprig.synth import PAPER_VELOCITIES, record_drops


def run(*, jobs: list[int], drops: int, velocities: int, repeats: int, object_id: str = "wood-beam",
        progress: Callable[[str], None] | None = None) -> list[dict]:
    """One row per entry of ``jobs`` (1 first: the baseline)."""
    say = progress or (lambda message: None)
    info = PAPER_OBJECTS[object_id]
    vs = PAPER_VELOCITIES[:velocities]
    rows, serial = [], None
    for n in sorted(set([1, *jobs])):
        times = []
        for r in range(repeats):
            t0 = time.perf_counter()
            out = record_drops(info, vs, drops, seed=7, workers=n)
            times.append(time.perf_counter() - t0)
            say(f"jobs={n} run {r + 1}/{repeats}: {times[-1]:.2f} s")
        serial = out if serial is None else serial
        rows.append({"jobs": n, "drops": len(vs) * drops, "median_s": statistics.median(times),
                     "min_s": min(times), "max_s": max(times), "identical": bool(np.array_equal(out, serial))})
    base = rows[0]["median_s"]
    for row in rows:
        row["speedup"] = base / row["median_s"]
    return rows


def table(rows: list[dict]) -> str:
    lines = ["| jobs | drops | median s [min, max] | speed-up vs jobs=1 | same arrays |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['jobs']} | {r['drops']} | {r['median_s']:.2f} [{r['min_s']:.2f}, {r['max_s']:.2f}] "
                     f"| {r['speedup']:.2f}x | {'yes' if r['identical'] else 'NO'} |")
    return "\n".join(lines)
