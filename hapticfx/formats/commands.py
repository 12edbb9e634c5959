"""``hapticfx export`` (an effect or a WAV file to platform haptic files) and ``hapticfx bench formats``."""

from __future__ import annotations

import time
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Optional

import typer

from ..cli.options import finite
from ..errors import HapticfxError

DEVICE_HELP = ("Actuator configuration that maps Hz to the file's 0-1 frequency and AHAP sharpness: quest (55-200 Hz, "
               "the default), console-pcm (20-250 Hz) or an .acf file.")


def _velocities(text: str) -> list[float]:
    """``LO:HI:STEP`` or a comma list of velocities (m/s): at least one, at most 1000, each a valid velocity."""
    from ..signal import valid_velocity

    usage = f"--velocities {text!r}: expected LO:HI:STEP (HI >= LO, STEP > 0) or a comma list"
    try:
        if ":" in text:
            lo, hi, step = (float(p) for p in text.split(":"))
            if not (step > 0 and hi >= lo):  # false for NaN too
                raise ValueError
            files = (hi - lo) / step + 1  # infinite for an infinite HI
            if not files < 1000.5:
                raise HapticfxError(f"--velocities {text!r} asks for {files:.4g} files; at most 1000")
            found = [round(lo + i * step, 6) for i in range(int(round(files)))]
        else:
            found = [float(p) for p in text.split(",") if p.strip()]
    except ValueError:
        raise HapticfxError(usage) from None
    if not 1 <= len(found) <= 1000:
        raise HapticfxError(f"{usage}, of 1 to 1000 velocities")
    try:
        return [valid_velocity(v) for v in found]
    except HapticfxError as exc:
        raise HapticfxError(f"--velocities {text!r}: {exc}") from None


def _wav_signal(path: Path):
    from ..actuators.files import read_wav
    from ..signal import Signal

    rate, samples = read_wav(path)
    return Signal(samples.mean(axis=0), float(rate))


def _refuse_existing(path: Path, force: bool) -> None:
    if path.exists() and not force:
        raise HapticfxError(f"{path}: exists; use --force to replace it")


@contextmanager
def _removed_on_failure(folder: Optional[Path]):
    """A block after which ``folder`` (one it made), should the block fail, is removed again if empty."""
    try:
        yield
    except BaseException:
        if folder is not None:
            with suppress(OSError):
                folder.rmdir()
        raise


def export(
    source: Path = typer.Argument(..., help="Effect file (YAML), or a WAV file (its channels are averaged)."),
    format: str = typer.Option(..., "--format", "-f", metavar="FORMAT",
                               help="haptic, ahap, android, android-ogg or hjif (or a plugin's format)."),
    out: Path = typer.Option(..., "--out", "-o", metavar="PATH",
                             help="Output file; with --velocities, a folder (made if missing)."),
    velocity: Optional[float] = typer.Option(None, "--velocity", "-v", metavar="M/S",
                                             help="Impact velocity in m/s (default: the "
                                             "effect's velocity_mps)."),
    velocities: Optional[str] = typer.Option(None, "--velocities", metavar="LO:HI:STEP",
                                             help="One file per velocity, LO:HI:STEP or a comma "
                                             "list (m/s), named EFFECT-V.VVmps.SUFFIX in the --out folder."),
    object: Optional[str] = typer.Option(None, "--object", metavar="OBJECT",
                                         help="Object id (default: the effect's object)."),
    device: str = typer.Option("quest", "--device", metavar="DEVICE", help=DEVICE_HELP),
    tolerance: float = typer.Option(0.01, "--tolerance", metavar="FRACTION", min=1e-4, max=0.5, callback=finite,
                                    help="Largest distance of the amplitude "
                                    "envelope from its breakpoints, fraction of full scale."),
    transients: bool = typer.Option(True, "--transients/--no-transients", help="Write a sharp onset as an emphasis "
                                    "(transient) in formats that hold one."),
    force: bool = typer.Option(False, "--force", help="Replace existing output files."),
):
    """Export an impact (what the effect's actuator would receive) or a WAV file to a platform haptic file.

    The analysis (amplitude envelope, breakpoints within --tolerance, frequency curve, transient at the
    onset) and each format's mapping are in docs/formats.md. What is written passes the format's rules:
    read it back with `hapticfx validate FILE`.
    """
    from . import format_named
    from .base import ExportOptions
    from .device import device_named

    fmt = format_named(format)
    options = ExportOptions(device=device_named(device), tolerance=tolerance, transients=transients)
    suffix = fmt.suffixes[0]
    if velocities is None and not out.name.lower().endswith(tuple(fmt.suffixes)):  # read by its name
        raise HapticfxError(f"{out}: {fmt.name} files are named *{' or *'.join(fmt.suffixes)}, which players and "
                            f"`hapticfx validate` read it by; give --out {out.name.split('.')[0] or 'impact'}{suffix}")
    if source.suffix.lower() == ".wav":
        if velocities or velocity is not None:
            raise HapticfxError("--velocity and --velocities apply to effects, not to a WAV file")
        signal = _wav_signal(source)
        _refuse_existing(out, force)
        t0 = time.perf_counter()
        fmt.write(out, signal, ExportOptions(**{**options.__dict__, "description": source.stem, "source": source.name}))
        typer.echo(f"wrote {out} ({out.stat().st_size} bytes, {signal.duration_s * 1000:.0f} ms of {source.name}, "
                   f"{(time.perf_counter() - t0) * 1000:.0f} ms)")
        return
    from ..atomic import together
    from ..cli.commands import _warn
    from ..pipeline import Pipeline

    if velocities is not None and velocity is not None:
        raise HapticfxError("give --velocity or --velocities, not both")
    speeds = None if velocities is None else _velocities(velocities)  # all of it checked before anything is made
    pipeline = Pipeline.from_effect(source, device="memory")
    if speeds is not None:
        from ..atomic import file_name_part

        targets = [(v, out / f"{file_name_part(pipeline.effect.name)}-{v:.2f}mps{suffix}") for v in speeds]
    else:
        targets = [(velocity, out)]
    for path, _ in ((p, v) for v, p in targets):
        _refuse_existing(path, force)
    made = speeds is not None and not out.exists()
    if speeds is not None:
        out.mkdir(parents=True, exist_ok=True)
    done = []  # said once every file is in place: a velocity the model refuses, say, leaves none of them
    with _removed_on_failure(out if made else None), together(path for _, path in targets):
        for i, (v, path) in enumerate(targets):
            delivery = pipeline.render(velocity=v, object=object)
            _warn(delivery)
            imp = delivery.impact
            described = ExportOptions(**{**options.__dict__, "source": source.name,
                                         "description": f"{pipeline.effect.name}: {imp.object} at {imp.velocity:.2f} m/s"})
            t0 = time.perf_counter()
            fmt.write(path, delivery.output, described)
            counter = f"[{i + 1}/{len(targets)}] " if len(targets) > 1 else ""
            done.append(f"{counter}wrote {path} ({path.stat().st_size} bytes; {imp.object} at {imp.velocity:.2f} m/s, "
                        f"{delivery.output.duration_s * 1000:.0f} ms; {(time.perf_counter() - t0) * 1000:.0f} ms)")
    for line in done:
        typer.echo(line)


def bench_formats(
    effects: list[Path] = typer.Argument(None, help="Effect files (default: every shipped effect)."),
    charts: Optional[Path] = typer.Option(None, "--charts", metavar="DIR",
                                          help="Write one PNG chart per format into this folder."),
    repeats: int = typer.Option(5, "--repeats", metavar="COUNT", min=1, max=100,
                                help="Exports timed per effect and format."),
    device: str = typer.Option("quest", "--device", metavar="DEVICE", help=DEVICE_HELP),
    as_json: Optional[Path] = typer.Option(None, "--json", metavar="FILE",
                                           help="Also write the rows as JSON to this file."),
):
    """Round trip of every effect through every format: envelope, spectral and perceptual error, size, time.

    Each effect is rendered for its actuator, exported, read back and rendered by the format's synthesis;
    the table compares the two (docs/formats.md says how each column is measured).
    """
    from ..bench.formats import run

    run(effects or None, charts=charts, repeats=repeats, device=device, as_json=as_json)


def register(app: typer.Typer, bench: typer.Typer) -> None:
    app.command("export")(export)
    bench.command("formats")(bench_formats)
