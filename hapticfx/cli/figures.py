"""Pictures of a rendered impact: the model's profile and what the actuator gets."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import atomic_path


def impact_png(path: Path, delivery, *, title: str, profile_units: str, volts_peak: float) -> Path:
    """Two panels with labelled axes and units; written atomically.

    A bare ``Figure`` (no pyplot, no GUI backend) with fixed margins: this picture is what a headless
    ``hapticfx play`` writes, and pyplot with a constrained layout cost about 0.25 s more a picture."""
    from matplotlib.figure import Figure

    prof, out = delivery.profile, delivery.output
    fig = Figure(figsize=(8, 5.5))
    fig.subplots_adjust(left=0.095, right=0.91, bottom=0.085, top=0.95, hspace=0.42)
    a, b = fig.subplots(2, 1)
    a.plot(prof.times() * 1000, prof.samples, lw=1.0, color="#1f5f99")
    a.set_xlabel("time (ms)")
    a.set_ylabel("acceleration (g)" if profile_units == "g" else "amplitude (fraction of full scale)")
    imp = delivery.impact
    a.set_title(f"{title}: {imp.object} at {imp.velocity:.2f} m/s, impact profile at {prof.rate_hz:g} Hz")
    a.grid(alpha=0.3)
    samples = np.atleast_2d(out.samples)
    for ch in samples:
        b.plot(out.times() * 1000, ch, lw=0.8, color="#b5532a")
    b.set_xlabel("time (ms)")
    b.set_ylabel("actuator input (fraction of full scale)")
    sec = b.secondary_yaxis("right", functions=(lambda x: x * volts_peak, lambda v: v / volts_peak))
    sec.set_ylabel("volts")
    lim = delivery.limiter
    b.set_title(f"actuator signal at {out.rate_hz:g} Hz; {lim.summary()}")
    b.grid(alpha=0.3)
    with atomic_path(Path(path)) as tmp:
        fig.savefig(tmp, dpi=110, format="png", metadata={"Software": "hapticfx"})
    return Path(path)
