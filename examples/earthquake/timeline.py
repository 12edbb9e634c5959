"""The PNG timeline: ground acceleration, head impacts, actuator output, and where on the head each landed."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hapticfx.atomic import atomic_path

COLOURS = {"plastic-frame": "tab:blue", "concrete-brick": "tab:red", "wood-beam": "tab:brown", "steel-plate": "tab:gray"}


def where_on_head(point) -> str:
    """A word for a point in the head frame (x right, y forward, z up): crown, front, back, left or right."""
    x, y, z = point
    if np.degrees(np.arctan2(z, np.hypot(x, y))) > 60:
        return "crown"
    azimuth = np.degrees(np.arctan2(x, y))  # 0 forward, 90 right
    return "front" if abs(azimuth) <= 45 else "back" if abs(azimuth) >= 135 else "right" if azimuth > 0 else "left"


def _head_map(ax_top, ax_side, contacts) -> None:
    """Where each impact landed: the head seen from above (x right, y forward) and from the right (y, z)."""
    import matplotlib.pyplot as plt

    radius = max([float(np.linalg.norm(c.point)) for c in contacts], default=0.13)
    for ax, (i, j), (xl, yl), view in ((ax_top, (0, 1), ("right (m)", "forward (m)"), "from above"),
                                       (ax_side, (1, 2), ("forward (m)", "up (m)"), "from the right")):
        ax.add_patch(plt.Circle((0, 0), radius, fill=False, color="0.5"))
        nose = np.array([0.0, 1.0] if view == "from above" else [1.0, 0.0])  # forward: the face
        ax.plot(*np.outer([0.95, 1.2], nose * radius).T, color="0.5", lw=2)
        for k, c in enumerate(sorted(contacts, key=lambda c: c.time_s)):
            colour = COLOURS.get(c.object, "k")
            ax.plot(c.point[i], c.point[j], "o", color=colour, ms=4 + 2 * c.velocity, alpha=0.7)
            ax.annotate(f"{c.time_s:.1f}s", (c.point[i], c.point[j]), fontsize=6, color=colour,
                        xytext=(4, 4 - 8 * (k % 2)), textcoords="offset points")
        ax.set_xlim(-1.4 * radius, 1.4 * radius)
        ax.set_ylim(-1.4 * radius, 1.4 * radius)
        ax.set_aspect("equal")
        ax.set_xlabel(xl, fontsize=8)
        ax.set_ylabel(yl, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_title(f"where on the head, {view}", fontsize=9)
    if not contacts:
        ax_top.text(0, 0, "no impact", ha="center", va="center", fontsize=8)


def plot_timeline(path: Path, *, ground: dict, contacts, output, duration_s: float, title: str) -> Path:
    """Four panels on one time axis, and a map of the head with where each impact landed;
    ``ground`` maps a label to a GroundMotion."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(15, 10))
    grid = fig.add_gridspec(4, 2, width_ratios=[4, 1.2], height_ratios=[2, 1.4, 1.5, 1.5])
    ax_g, ax_i, ax_o, ax_z = (fig.add_subplot(grid[r, 0]) for r in range(4))
    _head_map(fig.add_subplot(grid[0:2, 1]), fig.add_subplot(grid[2:4, 1]), contacts)
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

    # Plot a min/max envelope per pixel column rather than millions of samples; one colour per channel.
    channels = np.atleast_2d(output.samples)
    tints = ["tab:purple"] if len(channels) == 1 else [f"C{k}" for k in range(len(channels))]
    for k, (x, tint) in enumerate(zip(channels, tints)):
        bins = 3000
        per = max(1, x.size // bins)
        m = x[: per * (x.size // per)].reshape(-1, per)
        t = (np.arange(m.shape[0]) * per + per / 2) / output.rate_hz
        ax_o.fill_between(t, m.min(axis=1), m.max(axis=1), color=tint, lw=0, alpha=1 if len(channels) == 1 else 0.6,
                          label=None if len(channels) == 1 else f"channel {k}")
    if len(channels) > 1:
        ax_o.legend(loc="upper right", fontsize=7, ncol=len(channels))
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
    for x, tint in zip(channels, tints):
        ax_z.plot(np.arange(i0, i1, step) / output.rate_hz, x[i0:i1:step], color=tint, lw=0.6)
    ax_z.set_xlim(t0, t1)
    ax_z.set_ylim(-1.05, 1.05)
    ax_z.set_ylabel("actuator, zoom")
    ax_z.set_xlabel("time (s)")
    fig.tight_layout()
    with atomic_path(Path(path)) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)
