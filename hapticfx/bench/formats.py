"""``hapticfx bench formats``: every shipped effect through every format and back, against the original.

For each effect the impact its actuator would receive (after shaping and the safety limiter,
a fraction of full scale) is exported, read back and rendered by the format's synthesis at the
same rate. Columns:

- ``env``: RMS difference of the two amplitude envelopes (hapticfx.formats.analysis.envelope),
  divided by the original envelope's peak;
- ``dom``: the relative error of the dominant frequency (the peak of the magnitude spectrum);
- ``cent``: the relative error of the spectral centroid between 10 and 500 Hz;
- ``LSD``: log-spectral distance (dB, RMS over 10-500 Hz) of the two magnitude spectra, each floored
  at -60 dB of the original's peak (a synthesised carrier leaves other bands empty: without a floor
  the distance measures the floor);
- ``ST-SIM``, ``SPQI``: hapticfx.processing.perceptual, the measures the interpolators are scored with
  (at 2.8 kHz; full scale taken as 1 g);
- ``bytes``: the file's size; ``export ms``: median time of analysis and writing (``--repeats``).
"""

from __future__ import annotations

import json
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import HapticfxError
from ..progress import Progress
from ..signal import Signal
from ..timing import table

BAND_HZ = (10.0, 500.0)
NFFT = 1 << 17


@dataclass(frozen=True)
class Row:
    effect: str
    format: str
    envelope: float
    dominant_hz: float
    dominant_back_hz: float
    dominant: float
    centroid: float
    lsd_db: float
    st_sim: float
    spqi: float
    bytes: int
    export_ms: float


def shipped_effects() -> list[Path]:
    root = Path(__file__).resolve().parents[2] / "effects"
    return sorted(root.glob("*.yaml")) + sorted(root.glob("families/*.yaml"))


def _spectrum(x: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    f = np.fft.rfftfreq(NFFT, 1 / rate_hz)
    return f, np.abs(np.fft.rfft(x, NFFT))


def compare(x: np.ndarray, y: np.ndarray, rate_hz: float) -> dict:
    """The measures of ``y`` (a file read back) against ``x`` (the original), both at ``rate_hz``."""
    from ..processing import perceptual
    from ..formats.analysis import envelope

    y = np.pad(y[: len(x)], (0, max(0, len(x) - len(y))))
    ex, ey = envelope(x, rate_hz), envelope(y, rate_hz)
    f, sx = _spectrum(x, rate_hz)
    _, sy = _spectrum(y, rate_hz)
    band = (f >= BAND_HZ[0]) & (f <= BAND_HZ[1])
    fx, fy = f[np.argmax(sx)], f[np.argmax(sy)]
    cx = float(np.sum(f[band] * sx[band] ** 2) / max(np.sum(sx[band] ** 2), 1e-30))
    cy = float(np.sum(f[band] * sy[band] ** 2) / max(np.sum(sy[band] ** 2), 1e-30))
    floor = 1e-3 * max(sx[band].max(), 1e-30)
    lsd = float(np.sqrt(np.mean((20 * np.log10((sx[band] + floor) / (sy[band] + floor))) ** 2)))
    perceived = perceptual.scores(y, x[None], rate_hz=rate_hz)
    return {"envelope": float(np.sqrt(np.mean((ex - ey) ** 2)) / max(ex.max(), 1e-12)), "dominant_hz": float(fx),
            "dominant_back_hz": float(fy), "dominant": float(abs(fy - fx) / max(fx, 1e-9)),
            "centroid": abs(cy - cx) / max(cx, 1e-9), "lsd_db": lsd, "st_sim": perceived["stsim"], "spqi": perceived["spqi"]}


def variants(device):
    """(label, format, options) for every registered format, and .haptic without transients."""
    from ..formats import ExportOptions, all_formats

    out = []
    for fmt in all_formats():
        out.append((fmt.name, fmt, ExportOptions(device=device)))
        if fmt.name == "haptic":
            out.append(("haptic-notr", fmt, ExportOptions(device=device, transients=False)))
    return out


def measure(effects: list[Path], *, device: str = "quest", repeats: int = 5) -> list[Row]:
    from ..formats.device import device_named
    from ..pipeline import Pipeline

    dev = device_named(device)
    rows = []
    todo = []
    for label, fmt, options in variants(dev):  # a format whose optional dependency is missing is left out, said once
        try:
            with tempfile.TemporaryDirectory() as probe:
                fmt.write(Path(probe) / f"probe{fmt.suffixes[0]}", Signal(np.zeros(480), 48000.0), options)
            todo.append((label, fmt, options))
        except HapticfxError as exc:
            import typer

            typer.echo(f"hapticfx: warning: {label} left out: {exc}", err=True)
    with tempfile.TemporaryDirectory() as tmp, Progress(len(effects) * len(todo), "round trips") as progress:
        for effect in effects:
            delivery = Pipeline.from_effect(effect, device="memory").render()
            x = delivery.output
            for label, fmt, options in todo:
                path = Path(tmp) / f"{effect.stem}{fmt.suffixes[0]}"
                times = []
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    fmt.write(path, x, options)
                    times.append(time.perf_counter() - t0)
                y = fmt.read(path, dev, rate_hz=x.rate_hz).signal.samples
                rows.append(Row(effect.stem, label, bytes=path.stat().st_size, export_ms=1000 * float(np.median(times)),
                                **compare(x.samples, y, x.rate_hz)))
                progress.update(note=f"{effect.stem} {label}")
    return rows


def _median(values) -> float:
    finite = [v for v in values if np.isfinite(v)]
    return float(np.median(finite)) if finite else float("nan")


def _cell(v: float, fmt: str) -> str:
    return "-" if not np.isfinite(v) else format(v, fmt)


def print_tables(rows: list[Row]) -> str:
    per_effect = table(("effect", "format", "env", "dom Hz (back)", "dom", "cent", "LSD dB", "ST-SIM", "SPQI", "bytes",
                        "export ms"),
                       [(r.effect, r.format, f"{r.envelope:.3f}", f"{r.dominant_hz:.0f} ({r.dominant_back_hz:.0f})",
                         f"{r.dominant:.2f}", f"{r.centroid:.2f}", f"{r.lsd_db:.1f}", _cell(r.st_sim, ".2f"),
                         _cell(r.spqi, ".3f"), r.bytes, f"{r.export_ms:.1f}") for r in rows])
    names = list(dict.fromkeys(r.format for r in rows))
    summary = []
    for name in names:
        sel = [r for r in rows if r.format == name]
        med = lambda key: _median([getattr(r, key) for r in sel])  # noqa: E731
        summary.append((name, f"{med('envelope'):.3f} / {max(r.envelope for r in sel):.3f}",
                        f"{sum(r.envelope <= 0.05 for r in sel)}/{len(sel)}",
                        f"{sum(r.dominant <= 0.10 for r in sel)}/{len(sel)}", f"{med('centroid'):.2f}",
                        f"{med('lsd_db'):.1f}", _cell(med("st_sim"), ".2f"), _cell(med("spqi"), ".3f"),
                        f"{med('bytes'):.0f}", f"{med('export_ms'):.1f}"))
    summary_table = table(("format", "env median / worst", "env <= 0.05", "dom within 10%", "cent", "LSD dB", "ST-SIM",
                           "SPQI", "bytes", "export ms"), summary)
    return per_effect + "\n\nmedians over the effects:\n\n" + summary_table


def chart(rows: list[Row], name: str, out: Path) -> Path:
    """One PNG for one format: each measure per effect."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sel = [r for r in rows if r.format == name]
    labels = [r.effect.replace("falling_", "").replace("_", " ") for r in sel]
    panels = [("envelope error (of peak)", [r.envelope for r in sel], 0.05),
              ("dominant frequency error", [r.dominant for r in sel], 0.10),
              ("log-spectral distance (dB)", [r.lsd_db for r in sel], None),
              ("SPQI (1 = same)", [r.spqi for r in sel], None),
              ("file size (bytes)", [r.bytes for r in sel], None),
              ("export time (ms)", [r.export_ms for r in sel], None)]
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 12), sharex=True)
    for ax, (title, values, limit) in zip(axes, panels):
        ax.bar(range(len(sel)), np.nan_to_num(values), color="#2a6f97")
        if limit is not None:
            ax.axhline(limit, color="#c1121f", lw=1, ls="--")
        ax.set_ylabel(title, fontsize=8)
        ax.grid(axis="y", alpha=0.3)
    axes[-1].set_xticks(range(len(sel)), labels, rotation=60, ha="right", fontsize=7)
    fig.suptitle(f"round trip through {name}: every shipped effect", fontsize=10)
    fig.tight_layout()
    path = out / f"formats-{name}.png"
    fig.savefig(path, dpi=90, metadata={"Software": "hapticfx"})
    plt.close(fig)
    return path


def run(effects, *, charts: Path | None, repeats: int, device: str, as_json: Path | None) -> None:
    import typer

    paths = [Path(p) for p in effects] if effects else shipped_effects()
    missing = [str(p) for p in paths if not p.is_file()]
    if missing or not paths:
        raise HapticfxError(f"no such effect file: {', '.join(missing) or 'none given and no effects/ folder found'}")
    rows = measure(paths, device=device, repeats=repeats)
    typer.echo(print_tables(rows))
    if as_json is not None:
        as_json.write_text(json.dumps([asdict(r) for r in rows], indent=1, allow_nan=True) + "\n")
    if charts is not None:
        charts.mkdir(parents=True, exist_ok=True)
        for name in dict.fromkeys(r.format for r in rows):
            typer.echo(f"wrote {chart(rows, name, charts)}")
