"""``hapticfx devices`` and ``hapticfx bench output``."""

from __future__ import annotations

import numpy as np
import typer
from hapticfx.errors import SignalError


def devices():
    """List the sound output devices (index, name, host API, channels, default rate)."""
    from .devices import output_devices

    found = output_devices()
    if not found:
        typer.echo("no sound output devices (no sound card and no sound server; see docs/soundcard.md)")
        return
    typer.echo(f"{'':2}{'index':>5}  {'name':<32} {'host API':<10} {'out ch':>6} {'default Hz':>10} {'low latency':>11}")
    for d in found:
        mark = "*" if d.is_default else " "
        typer.echo(f"{mark:2}{d.index:>5}  {d.name[:32]:<32} {d.hostapi[:10]:<10} {d.channels:>6} "
                   f"{d.default_rate_hz:>10g} {d.default_low_latency_s * 1000:>9.1f}ms")
    typer.echo("* = default output; pick one with `actuator: {device: NAME or INDEX}` or --device")


def _row(label: str, values_s) -> str:
    """A table row: median, p99, min, max in ms of the heard clicks, and how many were lost."""
    v = np.asarray(values_s) * 1000
    heard = v[~np.isnan(v)]
    if not heard.size:
        return f"| {label} | - | - | - | - | {v.size} |"
    return (f"| {label} | {np.median(heard):.2f} | {np.percentile(heard, 99):.2f} | {heard.min():.2f} | "
            f"{heard.max():.2f} | {v.size - heard.size} |")


def bench_output(
    impacts: int = typer.Option(100, "--impacts", "-n", min=5, help="Clicks timed for the latency figures."),
    latencies: list[str] = typer.Option(["low", "0.004"], "--latency",
                                        callback=lambda values: [_latency(v) for v in values],
                                        help="Mixer stream latency to time: 'low', 'high' or seconds (repeatable)."),
    device: str = typer.Option("default", "--device", "-d", help="Sound output to time (its monitor must be the default input)."),
    seconds: float = typer.Option(1.0, "--seconds", min=0.1, help="Audio seconds mixed per capacity point."),
    repeats: int = typer.Option(3, "--repeats", min=1, help="Repeats per capacity point (median and spread)."),
    round_trips: int = typer.Option(200, "--round-trips", min=1, help="Solenoid commands timed."),
):
    """Output-path timings: first-sample latency (loopback capture), mixer capacity, solenoid round trip.

    Latency needs a sound server whose default input records the output (the PulseAudio
    null sink of .ci/soundserver.sh). The baseline is sounddevice.play(), one new stream
    per impact, timed the same way in the same run.
    """
    from hapticfx.params import BuildContext

    from . import bench
    from .actuator import VibroTransducer
    from .devices import import_sounddevice

    sd = import_sounddevice()
    typer.echo(f"## collision-to-first-sample latency ({impacts} clicks, ms)\n")
    typer.echo("| path | median | p99 | min | max | clicks lost |\n|---|---:|---:|---:|---:|---:|")
    medians = []
    for latency in latencies:
        params = VibroTransducer.Params(latency=latency)
        act = VibroTransducer(params, BuildContext(device=device))
        with act:
            rate = act.spec.rate_hz
            lat = bench.first_sample_latencies(act.play, rate, impacts,
                                               progress=lambda i: _progress(f"mixer {latency}", i, impacts))
            underflows = act.underflows
        typer.echo(_row(f"hapticfx mixer, latency {latency} ({underflows} stream underflows)", lat))
        medians.append(np.nanmedian(lat))
    base = bench.first_sample_latencies(lambda x: sd.play(x, rate, device=act_device(device), latency="low"),
                                        rate, impacts, progress=lambda i: _progress("sd.play", i, impacts))
    sd.stop()
    typer.echo(_row("baseline: sounddevice.play per impact", base))
    ratios = ", ".join(f"{lat_}: {np.nanmedian(base) / m:.2f}" for lat_, m in zip(latencies, medians))
    typer.echo(f"\nmedian latency ratio baseline / mixer ({ratios}; above 1: the mixer is faster)\n")

    typer.echo(f"## mixer capacity (one core, 48 kHz, 256-frame blocks, limiter on; {repeats} repeats)\n")
    typer.echo("| impacts at once | x real time (median) | min | max |\n|---:|---:|---:|---:|")
    capacity = 0
    voices = 1
    while voices <= 16384:
        runs = [bench.mix_real_time_factor(voices, seconds=seconds) for _ in range(repeats)]
        med = float(np.median(runs))
        typer.echo(f"| {voices} | {med:.1f} | {min(runs):.1f} | {max(runs):.1f} |")
        if med >= 1.0:
            capacity = voices
        else:
            break
        voices *= 2 if voices < 64 else 4
    typer.echo(f"\nlargest measured count mixed faster than real time: {capacity}\n")

    typer.echo("## solenoid command round trip (pseudo-terminal + emulator)\n")
    try:
        from hapticfx_solenoid.bench import round_trips as solenoid_round_trips
    except ImportError:
        typer.echo("the solenoid plugin (hapticfx-solenoid) is not installed; skipped")
        return
    rt = solenoid_round_trips(round_trips)
    typer.echo("| path (ms) | median | p99 | min | max | lost |\n|---|---:|---:|---:|---:|---:|")
    typer.echo(_row(f"solenoid command round trip ({round_trips})", rt))


def _latency(text: str | float) -> str | float:
    if text in ("low", "high") or isinstance(text, float):
        return text
    try:
        seconds = float(text)
    except ValueError:
        seconds = float("nan")
    if not 0.001 <= seconds <= 1.0:
        raise SignalError(f"--latency: expected 'low', 'high' or seconds in [0.001, 1], got {text!r}")
    return seconds


def act_device(device: str):
    """The PortAudio device index that ``device`` names (for the baseline)."""
    from .devices import resolve_device

    return resolve_device(device).index


def _progress(label: str, i: int, n: int) -> None:
    if i == n or i % 20 == 0:
        typer.echo(f"  {label}: {i}/{n} clicks", err=True)


def add_commands(app: typer.Typer, bench: typer.Typer) -> None:
    app.command("devices")(devices)
    bench.command("output")(bench_output)
