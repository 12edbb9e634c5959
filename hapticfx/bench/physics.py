"""``hapticfx bench physics``: physics tables against direct integration, and what they cost to build."""

from __future__ import annotations

import time
from pathlib import Path
import numpy as np

from ..errors import HapticfxError
from ..progress import Progress
from ..timing import table

FAMILIES = "effects/families"


def check(model, object_id: str, velocities: np.ndarray, progress=None) -> dict:
    """Largest table-vs-direct difference over ``velocities``, relative to the direct profile's peak at each."""
    info = model.object_for(object_id)
    tab = model.table_for(info)
    worst, at, direct_s, table_s = 0.0, None, 0.0, 0.0
    for v in velocities:
        t0 = time.perf_counter()
        ref = model._profile(info, float(v))
        t1 = time.perf_counter()
        got = model._finish(tab.profile(float(v)))
        table_s += time.perf_counter() - t1
        direct_s += t1 - t0
        peak = float(np.max(np.abs(ref)))
        err = float(np.max(np.abs(got - ref))) / peak if peak > 0 else float(np.max(np.abs(got)))
        if err > worst:
            worst, at = err, float(v)
        if progress:
            progress()
    n = len(velocities)
    half = 0.5 * float(tab.velocities[0])  # below the knots: the first knot's profile scaled
    ref = model._profile(info, half)
    below = float(np.max(np.abs(model._finish(tab.profile(half)) - ref)) / np.max(np.abs(ref)))
    return {"worst": worst, "at": at, "below": below, "direct_ms": 1e3 * direct_s / n, "table_ms": 1e3 * table_s / n,
            "build_s": tab.table.meta.get("build_s"), "knots": len(tab.velocities), "nodes": tab.table.n_nodes,
            "v_floor": float(tab.velocities[0]), "v_max": tab.v_max}


def run(effects: list[Path] | None = None, *, velocities: int = 10000, seed: int = 0) -> str:
    """``hapticfx bench physics``: the table of every effect's table against direct integration."""
    from ..pipeline import Pipeline

    paths = [Path(p) for p in (effects or sorted(Path(FAMILIES).glob("*.yaml")))]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise HapticfxError(f"effect file(s) not found: {', '.join(missing)} (run from the repository root or "
                            "name the files)")
    rows = []
    rng = np.random.default_rng(seed)
    with Progress(len(paths) * velocities, "integrate", unit="impacts") as bar:
        for path in paths:
            pipeline = Pipeline.from_effect(path, device="memory")
            model = pipeline.model
            if getattr(model, "name", "") != "contact":
                raise HapticfxError(f"{path}: model {model.name!r} has no physics table (contact only)")
            tab = model.table_for(model.object_for(pipeline.effect.object_id))
            vs = rng.uniform(float(tab.velocities[0]), tab.v_max, size=velocities)
            r = check(model, pipeline.effect.object_id, vs, progress=bar.update)
            rows.append([path.stem, f"{r['v_floor']:.3g}-{r['v_max']:g}", f"{r['worst']:.2e} at {r['at']:.4g}",
                         f"{r['below']:.1e}", f"{r['direct_ms']:.1f}", f"{r['table_ms']:.3f}", r["knots"], r["nodes"],
                         r["build_s"]])
    return (f"physics tables against direct integration, {velocities} random velocities per effect; error: largest "
            "|table - direct| / peak of direct at that velocity\n"
            + table(["effect", "table range (m/s)", "worst error", "error at half the first knot", "direct ms",
                     "table ms", "knots", "nodes", "build s"], rows))


