"""``hapticfx bench families``: each impact family against the published quantities it must match.

Measures from the contact model itself (``table: false`` physics, the same the
tables are built from): the contact time and the coefficient of restitution of
the first contact, and, for the tapping families, the decaying sinusoid the
stylus rings with. :data:`PUBLISHED` lists what each family is checked against
and where the range comes from; docs/families.md shows the table and
tests/test_families_published.py fails when a family leaves its range.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import HapticfxError
from ..timing import table

FAMILIES = Path("effects/families")


@dataclass(frozen=True)
class Check:
    """One published quantity a family must match: how to measure it, the range, the source."""

    family: str
    quantity: str
    source: str
    low: float
    high: float
    measure: Callable[[object], float]
    note: str = ""


def direct_model(path: Path, **changes):
    """The family's contact model integrating every impact (what its table is built from), with ``changes``."""
    from ..effect import load_effect
    from ..pipeline import Pipeline

    effect = load_effect(path)
    options = {**effect.model.options, "table": False, **changes}
    effect = dataclasses.replace(effect, model=dataclasses.replace(effect.model, options=options))
    pipeline = Pipeline(effect, device="memory")
    return pipeline.model, pipeline.model.object_for(effect.object_id)


def collision(model, info, velocity: float, *, rigid: bool = False) -> tuple[float, float]:
    """Contact time (s) and coefficient of restitution (relative normal speed after / before) of the first contact
    at ``velocity``; ``rigid``: against an immovable receiver (a test wall)."""
    from ..droprig.state import VH, VY

    scene = model.scene(info, velocity)[0]
    if rigid:
        scene = dataclasses.replace(scene, helmet=dataclasses.replace(scene.helmet, mass=1e6))
    m, k = info.mass_kg, scene.stiffness
    estimate = 3.2 * (m / k) ** 0.4 * velocity ** -0.2
    span = 6.0 * estimate
    sol = scene.integrate(span, rtol=1e-10)
    t = np.linspace(0.0, span, 20001)
    states = sol.sol(t)
    delta = np.array([scene.closest(states[:, i])[0] for i in range(t.size)])
    inside = delta > 0
    if not inside[0] and not inside[1]:
        raise HapticfxError("no contact at the start of the collision")
    end = int(np.argmax(~inside[1:])) + 1 if not inside[1:].all() else t.size - 1
    rel = states[VY, end] - states[VH, end]
    return float(t[end]), float(rel / velocity)


def ringing(samples: np.ndarray, rate_hz: float) -> tuple[float, float, float]:
    """A decaying sinusoid ``A exp(-B t) sin(2 pi f t)`` fitted to the ringing after the largest sample:
    frequency f (Hz, the spectrum's peak), decay rate B (1/s, the slope of the log of the successive peaks) and
    amplitude A (the first peak's)."""
    start = int(np.argmax(np.abs(samples)))
    x = samples[start:]
    n = 16 * x.size
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size), n))
    freqs = np.fft.rfftfreq(n, 1.0 / rate_hz)
    usable = freqs > 10.0
    f = float(freqs[usable][np.argmax(spec[usable])])
    mag = np.abs(x)
    peaks = [i for i in range(1, mag.size - 1) if mag[i] >= mag[i - 1] and mag[i] > mag[i + 1]]
    peaks = [i for i in peaks if mag[i] > 0.02 * mag.max()]
    if len(peaks) < 3:
        return f, float("inf"), float(mag.max())
    ti = np.array(peaks) / rate_hz
    slope = np.polyfit(ti, np.log(mag[peaks]), 1)[0]
    return f, float(-slope), float(mag.max())


def _cor_on_ash(path: Path) -> Callable[[object], float]:
    return lambda _: collision(*direct_model(path), 85 * 0.3048, rigid=True)[1]


def _contact_ms(path: Path, velocity: float) -> Callable[[object], float]:
    return lambda _: 1e3 * collision(*direct_model(path), velocity)[0]


def _bounce_hz(path: Path, velocity: float) -> Callable[[object], float]:
    """The frequency of a bounce whose first contact lasts half its period: 1 / (2 x contact time)."""
    return lambda _: 1.0 / (2.0 * collision(*direct_model(path), velocity)[0])


def _cor_falls(path: Path, low: float, high: float) -> Callable[[object], float]:
    def measure(_):
        model, info = direct_model(path)
        return collision(model, info, high)[1] - collision(model, info, low)[1]
    return measure


def _rings(path: Path, velocity: float) -> tuple[float, float, float]:
    """:func:`ringing` of the family's profile at ``velocity``, integrated directly."""
    model, info = direct_model(path)
    return ringing(model._profile(info, velocity), model.params.rate_hz)


def _tap(path: Path, what: int) -> Callable[[object], float]:
    return lambda _: _rings(path, 0.2)[what]


def _tap_linearity(path: Path) -> Callable[[object], float]:
    def measure(_):
        a = [_rings(path, v)[2] / v for v in (0.1, 0.2, 0.4)]
        return max(a) / min(a) - 1.0
    return measure


def _rises_with_hardness(paths: list[Path], what: int) -> Callable[[object], float]:
    """The smallest ratio of a tap's ringing quantity (``ringing``'s index ``what``) at 0.2 m/s between each
    surface and the next softer one (``paths`` from soft to hard): above 1 where it rises with hardness."""
    def measure(_):
        values = [_rings(path, 0.2)[what] for path in paths]
        return min(b / a for a, b in zip(values, values[1:]))
    return measure


KAGAN = ("Kagan and Atkinson, 'The coefficient of restitution of baseballs as a function of relative humidity', "
         "The Physics Teacher: the rules require a ball shot at 85 ft/s at a wall of northern white ash to rebound "
         "at 0.546 +- 0.032 of its speed")
ADAIR = ("HowStuffWorks, 'How the physics of baseball works: the bat/ball collision', citing Adair: the force acts "
         "on the ball 'in one millisecond'")
ANDERSEN = ("Andersen, Kristensen and Sorensen, 'Biomechanical differences between toe and instep kicking', "
            "Football Science 5 (2008): in kicks and pendulum impacts 'the COR dropped with increased impact "
            "velocity' (ball speeds 11.5-22.2 m/s)")
MOTOIQ = ("MotoIQ, 'Garage Love: Speed-Dependent Wheel Vibrations', quoting an engineer on the wheel-hop resonance "
          "(tyre and suspension springs, unsprung mass): 'this frequency typically occurs in the 10-15 Hz range'")
HARDER = ("eLife reviewed preprint 111461 (elifesciences.org/reviewed-preprints/111461), introduction, on tapping: "
          "'Hard surfaces produce higher-amplitude, higher-frequency transients'")
OKAMURA = ("Okamura, Cutkosky and Dennerlein, 'Reality-based models for vibration feedback in virtual "
           "environments', IEEE/ASME Trans. Mechatronics 6(3), 2001 (abstract): a tap on a real material, measured "
           "at the stylus, is a decaying sinusoid (amplitude, frequency, decay rate)")


def checks(folder: Path = FAMILIES) -> list[Check]:
    """What each family is checked against (the ranges marked 'reading' are this project's reading of the
    source, not a number it prints)."""
    bat, ball = folder / "bat_ball.yaml", folder / "football_kick.yaml"
    out = [
        Check("bat_ball", "COR, baseball on a rigid wall at 85 ft/s", KAGAN, 0.514, 0.578, _cor_on_ash(bat)),
        Check("bat_ball", "contact time at 40 m/s (ms)", ADAIR, 0.5, 1.5, _contact_ms(bat, 40.0),
              note="reading: 'one millisecond' taken as 0.5-1.5 ms"),
        Check("football_kick", "COR at 22.2 m/s minus COR at 11.5 m/s", ANDERSEN, -1.0, -1e-3,
              _cor_falls(ball, 11.5, 22.2), note="reading: the COR falls with speed (sign only)"),
    ]
    for name in ("rubber", "wood", "aluminium"):
        path = folder / f"tapping_{name}.yaml"
        if not path.is_file():
            continue
        out.append(Check(f"tapping_{name}", "ringing: decay rate B (1/s) at 0.2 m/s", OKAMURA, 1.0, 1e3,
                         _tap(path, 1), note="reading: a decaying sinusoid (B finite, > 0); the published "
                         "B was not read here"))
        out.append(Check(f"tapping_{name}", "amplitude per unit velocity, 0.1-0.4 m/s: spread", OKAMURA, 0.0, 0.25,
                         _tap_linearity(path), note="reading: amplitude proportional to velocity "
                         "(the spread of A/v)"))
        out.append(Check(f"tapping_{name}", "ringing frequency f (Hz) at 0.2 m/s (rendered only)", OKAMURA,
                         float("nan"), float("nan"), _tap(path, 0), note="the published f was not read here"))
    surfaces = [folder / f"tapping_{name}.yaml" for name in ("rubber", "wood", "aluminium")]
    if all(path.is_file() for path in surfaces):
        for what, label in ((0, "frequency f"), (2, "amplitude A")):
            out.append(Check("tapping", f"ringing {label} at 0.2 m/s, rubber < wood < aluminium: smallest ratio",
                             HARDER, 1.0 + 1e-9, 1e3, _rises_with_hardness(surfaces, what),
                             note="reading: the order only (each surface's over the next softer one's)"))
    out.append(Check("wheel_bump", "wheel on its tyre: 1 / (2 x contact time) at 1.2 m/s (Hz)", MOTOIQ, 10.0, 15.0,
                     _bounce_hz(folder / "wheel_bump.yaml", 1.2),
                     note="reading: the first contact is half a bounce of the wheel on its tyre, taken as the "
                     "wheel-hop frequency (the model has no suspension spring at the wheel)"))
    return out


def run(plot: Path | None = None) -> str:
    """``hapticfx bench families``: every check's table, the sources, and the spectra figure when asked."""
    rows = []
    for c in checks():
        value = c.measure(None)
        ok = "-" if np.isnan(c.low) else ("yes" if c.low <= value <= c.high else "NO")
        rng = "not read" if np.isnan(c.low) else f"{c.low:g} to {c.high:g}"
        rows.append([c.family, c.quantity, rng, f"{value:.4g}", ok, c.note or "from the source"])
    text = table(["family", "quantity", "range", "rendered", "in range", "range from"], rows)
    text += "\n\nsources:\n" + "\n".join(f"- {s}" for s in (KAGAN, ADAIR, ANDERSEN, OKAMURA))
    if plot is not None:
        text += f"\nwrote {spectra_png(plot)}"
    return text


def receiver_spectrum(stem: str) -> tuple[str, np.ndarray, np.ndarray, float]:
    """The struck body's acceleration spectrum for family ``stem`` at its default velocity (integrated directly):
    receiver name, frequencies (Hz, 1-1000), level (dB re the peak) and the dominant frequency."""
    from ..effect import load_effect

    model, info = direct_model(FAMILIES / f"{stem}.yaml", felt="receiver")
    x = model._profile(info, load_effect(FAMILIES / f"{stem}.yaml").velocity_mps)
    n = 8 * x.size
    spec = np.abs(np.fft.rfft(x, n))
    freqs = np.fft.rfftfreq(n, 1.0 / model.params.rate_hz)
    keep = (freqs > 1.0) & (freqs < 1000.0)
    db = 20 * np.log10(spec[keep] / spec[keep].max())
    return model.params.receiver, freqs[keep], db, float(freqs[keep][np.argmax(db)])


FOUR = ("bat_ball", "football_kick", "tapping", "wheel_bump")


def spectra_png(path: Path) -> Path:
    """The struck bodies' spectra for the four families, each at its default velocity, with the dominant peak."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..atomic import atomic_path

    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    for stem in FOUR:
        receiver, freqs, db, peak = receiver_spectrum(stem)
        ax.semilogx(freqs, db, lw=1.1, label=f"{stem} ({receiver}): peak {peak:.0f} Hz")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("receiver's acceleration spectrum (dB re its peak)")
    ax.set_ylim(-60, 3)
    ax.set_title("the struck body of each family rings at its own frequencies")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    with atomic_path(Path(path), make_parents=True) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)
