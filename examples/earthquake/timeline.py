"""The PNG timeline: ground acceleration, head impacts, actuator output."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hapticfx.atomic import atomic_path

COLOURS = {"plastic-frame": "tab:blue", "concrete-brick": "tab:red", "wood-beam": "tab:brown", "steel-plate": "tab:gray"}


def plot_timeline(path: Path, *, ground: dict, contacts, output, duration_s: float, title: str) -> Path:
    """Three panels on one time axis; ``ground`` maps a label to a GroundMotion."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_g, ax_i, ax_o, ax_z) = plt.subplots(4, 1, figsize=(12, 10), gridspec_kw={"height_ratios": [2, 1.4, 1.5, 1.5]})
    ax_i.sharex(ax_g)
    ax_o.sharex(ax_g)
    for label, gm in ground.items():
        gm = gm.fitted_to(duration_s)
        ax_g.plot(gm.times(), gm.accel_g, lw=0.6, label=f"{label}: {gm.name} (PGA {gm.pga_g:.2f} g)")
    ax_g.set_ylabel("ground accel. (g)")
    ax_g.legend(loc="upper right", fontsize=7)
    ax_g.set_title(title, fontsize=10)

    top = max([c.velocity for c in contacts], default=1.0)
    for k, c in enumerate(sorted(contacts, key=lambda c: c.time_s)):
        colour = COLOURS.get(c.object, "k")
        ax_z.axvline(c.time_s, color=colour, lw=0.8, ls=":")
        ax_i.vlines(c.time_s, 0, c.velocity, color=colour, lw=2)
        ax_i.plot(c.time_s, c.velocity, "o", color=colour)
        # stagger the labels: impacts often come seconds apart on a 60 s axis
        ax_i.annotate(f"{c.object} {c.velocity:.2f} m/s", (c.time_s, c.velocity), fontsize=7, color=colour,
                      xytext=(c.time_s + 0.01 * duration_s, top * (1.75 - 0.2 * (k % 5))),
                      arrowprops={"arrowstyle": "-", "color": colour, "lw": 0.5})
    if not contacts:
        ax_i.text(0.5, 0.5, "no object hit the head", transform=ax_i.transAxes, ha="center")
    ax_i.set_ylim(0, top * 1.9)
    ax_i.set_ylabel("impact velocity (m/s)")

    # Plot a min/max envelope per pixel column rather than millions of samples.
    x = output.samples
    bins = 3000
    per = max(1, x.size // bins)
    m = x[: per * (x.size // per)].reshape(-1, per)
    t = (np.arange(m.shape[0]) * per + per / 2) / output.rate_hz
    ax_o.fill_between(t, m.min(axis=1), m.max(axis=1), color="tab:purple", lw=0)
    ax_o.set_ylim(-1.05, 1.05)
    ax_o.set_ylabel("actuator (full scale)")
    ax_o.set_xlim(0, duration_s)

    # The impacts up close: the actuator samples around them.
    if contacts:
        t0 = max(0.0, min(c.time_s for c in contacts) - 0.2)
        t1 = min(duration_s, max(c.time_s for c in contacts) + 0.4)
    else:
        t0, t1 = 0.0, min(duration_s, 1.0)
    i0, i1 = int(t0 * output.rate_hz), int(t1 * output.rate_hz)
    step = max(1, (i1 - i0) // 20000)
    ax_z.plot(np.arange(i0, i1, step) / output.rate_hz, x[i0:i1:step], color="tab:purple", lw=0.6)
    ax_z.set_xlim(t0, t1)
    ax_z.set_ylim(-1.05, 1.05)
    ax_z.set_ylabel("actuator, zoom")
    ax_z.set_xlabel("time (s)")
    fig.tight_layout()
    with atomic_path(Path(path)) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)
