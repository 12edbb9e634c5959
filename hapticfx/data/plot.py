"""Figures of a dataset: the drops at one velocity with the chosen representative
(like the paper's Fig. 6a) and one object's representative profiles across
velocities (like Fig. 6b)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from .dataset import Dataset


def plot_object(ds: Dataset, object_id: str, out: Path, *, reducer: str = "max-min", velocity: float | None = None) -> Path:
    """Write a two-panel PNG for ``object_id``; returns its path.

    Left: every drop at ``velocity`` (default: the middle recorded velocity),
    reduced with ``reducer``, with the representative drawn bold. Right: the
    bank's representative profiles, one per velocity.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from ..registry import get_registry

    bank = ds.bank(object_id, reducer)
    velocities, windows = ds.windows(object_id)
    rep = ds.representatives(object_id)
    if velocity is None:
        i = len(velocities) // 2
    else:
        from .build import recorded_index

        i = recorded_index(object_id, velocities, velocity)
    drops = get_registry().create("reducer", reducer).reduce(windows[i])
    chosen = int(rep["chosen"][i])
    t_ms = np.arange(drops.shape[-1]) / ds.rate_hz * 1000.0
    manual = any(abs(o["velocity_mps"] - velocities[i]) <= 1e-6 for o in rep.get("overrides", []))

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    for d, x in enumerate(drops):
        if d != chosen:
            a.plot(t_ms, x, lw=0.7, alpha=0.45, color="0.45")
    a.plot(t_ms, drops[chosen], lw=1.8, color="C3")
    # what the red line is goes in the title: a legend box would cover the data
    a.set(title=f"{ds.object_info(object_id).name}: {len(drops)} drops at {velocities[i]:.2f} m/s ({reducer})\n"
                f"red: the representative, drop {chosen} ({'chosen by hand' if manual else 'medoid'})",
          xlabel="time (ms)", ylabel="acceleration (g)")
    cmap = plt.get_cmap("viridis")
    vs = np.asarray(bank.velocities, dtype=float)
    norm = plt.Normalize(vs.min(), vs.max() if vs.max() > vs.min() else vs.min() + 1.0)
    for k in range(len(bank)):
        b.plot(t_ms[: bank.n_samples], bank.profiles[k], lw=0.9, color=cmap(norm(vs[k])))
    b.set(title=f"{ds.object_info(object_id).name}: representative profiles ({reducer})",
          xlabel="time (ms)", ylabel="acceleration (g)")
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=b, pad=0.01)  # beside, not over, the data
    bar.set_label("impact velocity (m/s)")
    bar.set_ticks(vs)
    out = Path(out)
    try:
        with atomic_path(out, make_parents=True) as tmp:
            fig.savefig(tmp, dpi=110, format="png", metadata={"Software": "hapticfx"})  # ours to replace
    finally:
        plt.close(fig)
    return out
