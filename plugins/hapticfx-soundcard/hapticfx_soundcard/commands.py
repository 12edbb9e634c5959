"""``hapticfx devices``, ``hapticfx bench output``, ``hapticfx bench helmet`` and ``hapticfx bench safety``."""

from __future__ import annotations

import json
import os
import platform
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from hapticfx.cli.options import finite
from hapticfx.errors import HapticfxError, SignalError
from hapticfx.progress import Progress, say


def devices(as_json: bool = typer.Option(False, "--json", help="Print JSON (for programs) instead of the table.")):
    """List the sound output devices (index, name, host API, channels, default rate)."""
    import dataclasses
    import json

    from .devices import output_devices

    found = output_devices()
    if as_json:
        typer.echo(json.dumps([dataclasses.asdict(d) for d in found], indent=2))
        return
    if not found:
        typer.echo("no sound output devices (no sound card and no sound server; see docs/soundcard.md)")
        return
    typer.echo(f"{'':2}{'index':>5}  {'name':<32} {'host API':<10} {'out ch':>6} {'default Hz':>10} {'low latency':>11}")
    for d in found:
        mark = "*" if d.is_default else " "
        typer.echo(f"{mark:2}{d.index:>5}  {d.name[:32]:<32} {d.hostapi[:10]:<10} {d.channels:>6} "
                   f"{d.default_rate_hz:>10g} {d.default_low_latency_s * 1000:>9.1f}ms")
    typer.echo("* = default output; pick one with `actuator: {device: NAME or INDEX}` or --device")


def _row(label: str, values_s, floor=None) -> str:
    """A table row: median, p99, min, max in ms of the heard impacts, how many were lost, and
    the median and p99 above the floor's."""
    v = np.asarray(values_s) * 1000
    heard = v[~np.isnan(v)]
    if not heard.size:
        return f"| {label} | - | - | - | - | {v.size} | - | - |"
    med, p99 = np.median(heard), np.percentile(heard, 99)
    above = ("-", "-") if floor is None else (f"{med - floor[0]:+.2f}", f"{p99 - floor[1]:+.2f}")
    return (f"| {label} | {med:.2f} | {p99:.2f} | {heard.min():.2f} | {heard.max():.2f} | {v.size - heard.size} "
            f"| {above[0]} | {above[1]} |")


DEFAULT_EFFECTS = ("effects/falling_brick_kinetic.yaml", "effects/falling_brick_linear.yaml",
                   "effects/falling_brick.yaml", "effects/falling_brick_convbilstm.yaml")
STALL_S = 0.005  # a machine stall this long can empty a 'low' buffer that is already half played
# The first callback after a stall reports its underflow: 0.7-17.7 ms after it ended in docs/benchmarks.md.
STALL_WINDOW_S = 0.02
BLOCKS = (48, 104, 256)  # 48: PortAudio's block at a 4 ms buffer here; 104: at 'low'; 256: a common setting


def _latency_section(effects: list[Path], impacts: int, latency, max_latency: float | None, device: str,
                     gap_s: float, queue: float | None, ahead: float | None) -> None:
    import socket
    import tempfile

    from hapticfx.engine import Engine
    from hapticfx.osc import OscBridge, encode_impact
    from hapticfx.params import BuildContext

    from .bench import output as bench
    from .actuator import VibroTransducer

    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "bench-output.yaml"
        names = [p.stem for p in effects]
        given = {"latency": latency, "max_latency": max_latency, "queue": queue, "ahead": ahead}
        options = {k: v for k, v in given.items() if v is not None}
        lines = [f"name: bench-output\nactuators:\n  helmet: {{type: vibro-transducer, device: {device!r}, "
                 + ", ".join(f"{k}: {v!r}" for k, v in options.items()) + "}\neffects:"]
        osc_object = names[-2] if len(names) > 1 else names[0]
        entries = [*zip(names, effects), (f"osc-{osc_object}", effects[names.index(osc_object)])]
        lines += [f"  {n}: {{effect: {str(p.resolve())!r}, actuator: helmet, channel: 0}}" for n, p in entries]
        scene.write_text("\n".join(lines) + "\nengine: {queue_size: 16}\n")
        paths: dict[str, bench.TimedPath] = {}

        def played(p):
            paths[p.object].signals.append(p.signal.samples)

        with Engine(scene, on_played=played) as engine:
            floor_act = VibroTransducer(VibroTransducer.Params(**options), BuildContext(device=device, channel=1))
            with floor_act:
                rate = floor_act.spec.rate_hz
                ready = bench.click(rate)
                floor = bench.TimedPath("floor: a ready click into the same stream", None, 1)

                def floor_send(v):
                    floor_act.play(ready)
                    floor.signals.append(ready)

                floor.send = floor_send
                paths["floor"] = floor
                for n in names:
                    paths[n] = bench.TimedPath(n, lambda v, n=n: engine.impact(n, v), 0)
                bridge = OscBridge(engine.submit, engine.objects, port=0, rate_hz=0)
                with bridge, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
                    addr = bridge.address
                    paths[f"osc-{osc_object}"] = bench.TimedPath(f"OSC datagram, {osc_object}", lambda v: client.sendto(
                        encode_impact(f"osc-{osc_object}", v), addr), 0)
                    buffer_s = floor_act.output_latency_s
                    cap = floor_act.params.max_latency
                    queued = floor_act.queue_s
                    what = f"queue {queued:g} s" if queued else f"latency {latency}"
                    with Progress(impacts, what, unit="rounds") as bar:
                        rounds = bench.send_rounds(
                            list(paths.values()), rate, impacts, gap_s=gap_s,
                            output=floor_act, progress=lambda i: bar.update())
                    late = floor_act.losses().get("late", 0)
            stats = engine.close()
    lat = bench.first_sample_latencies(list(paths.values()), rounds.capture, gap_s=gap_s)
    if queued:
        stream = (f"### queue {queued * 1e3:g} ms at the server, impacts written {buffer_s * 1e3:g} ms ahead of playback "
                  f"({late} written after the server had read their start): ")
    else:
        stream = (f"### stream latency {latency}: output buffer {buffer_s * 1e3:.1f} ms (max_latency {cap:g} s"
                  + "".join(f"; then {b * 1e3:.1f} ms" for b in _buffers(paths) if b != buffer_s) + "); ")
    typer.echo(f"\n{stream}{impacts} impacts per path, {gap_s:g} s apart, paths interleaved; "
               f"engine: {stats['rendered']} played, {stats['failed']} failed, {stats['dropped_queue_full']} dropped\n")
    _underflow_report(rounds, impacts * len(paths), queued or buffer_s)
    typer.echo("\n".join(_latency_tables(paths, lat)))


def _buffers(paths: dict) -> list[float]:
    """The output buffers the sends went out at, in the order the run used them."""
    return list(dict.fromkeys(b for p in paths.values() for b in p.buffers_s))


def _latency_tables(paths: dict, lat: dict[str, np.ndarray]) -> list[str]:
    """One table per output buffer the run used (in order), each path against the floor clicks
    (``paths["floor"]``) sent at that buffer."""
    buffers = _buffers(paths)
    out = []
    for b in buffers:
        at = {key: np.array(p.buffers_s) == b for key, p in paths.items()}
        if len(buffers) > 1:
            out.append(f"Sent while the output buffer was {b * 1e3:.1f} ms ({int(at['floor'].sum())} floor clicks):\n")
        floor_lat = lat[paths["floor"].name][at["floor"]] * 1000
        heard = floor_lat[~np.isnan(floor_lat)]
        ref = (np.median(heard), np.percentile(heard, 99)) if heard.size else None
        out.append("| path (ms) | median | p99 | min | max | not heard | median - floor | p99 - floor |\n"
                   "|---|---:|---:|---:|---:|---:|---:|---:|")
        for key, p in paths.items():
            label = p.name if key == "floor" or key.startswith("osc-") else f"Engine.impact, {p.name}"
            out.append(_row(label, lat[p.name][at[key]], None if key == "floor" else ref))
        out.append("")
    return out


def _underflow_report(rounds, sends: int, buffer_s: float) -> None:
    """The underflows during the sends, set against the machine's own stalls over the same time."""
    machine = rounds.machine
    stalls = np.array([s.seconds for s in machine.stalls]) * 1e3
    long = [s for s in machine.stalls if s.seconds >= STALL_S]
    longest = max(machine.stalls, key=lambda s: s.seconds, default=None)
    causes = rounds.put_down_to_machine(within_s=STALL_WINDOW_S, at_least_s=STALL_S)
    typer.echo(
        f"{len(rounds.underflow_times)} stream underflows during the {sends} sends ({rounds.settling} before them, "
        f"while the streams settled); the recording's own overflows: {rounds.capture_overflows}. Machine stalls "
        f"over the same {machine.seconds:.0f} s (a probe per CPU, scheduler {machine.policy!r}): "
        f"{len(long)} of {STALL_S * 1e3:g} ms or more ({sum(map(machine.everywhere, long))} of them on every CPU "
        f"at once), "
        f"{int((stalls >= buffer_s * 1e3).sum())} longer than the buffer"
        + (f", the longest {longest.seconds * 1e3:.1f} ms on CPU {longest.cpu}" if longest else "")
        + "".join(f"; the host's steal time, CPU {cpu}: {s * 1e3:.0f} ms" for cpu, s in machine.steal_s.items())
        + f". Underflows within {STALL_WINDOW_S * 1e3:g} ms after such a stall: "
        f"{sum(c is not None for c in causes)} of {len(causes)}. Audio callbacks that came longer than the buffer "
        f"after the one before (the stream unfed that long): {len(rounds.late_callbacks)}"
        + (f", the longest gap {max(g for _, g in rounds.late_callbacks) * 1e3:.1f} ms"
           if rounds.late_callbacks else "") + ".\n")
    if causes:
        typer.echo("| underflow | machine stall before it | callback gap before it |\n|---|---|---|")
        for t, stall in zip(rounds.underflow_times, causes):
            what = (f"{stall.seconds * 1e3:.1f} ms on CPU {stall.cpu}"
                    f"{' (every CPU at once)' if machine.everywhere(stall) else ''}, "
                    f"ended {(t - stall.end) * 1e3:.1f} ms before" if stall else f"none of {STALL_S * 1e3:g} ms or more")
            gap = rounds.gap_before(t)
            typer.echo(f"| +{t - machine.started:.1f} s | {what} | "
                       f"{f'{gap * 1e3:.1f} ms' if gap is not None else 'none longer than the buffer'} |")
        typer.echo("")


def bench_output(
    effects: Optional[list[Path]] = typer.Argument(None, help="Effects whose models are timed (default: the falling "
                                                             "brick with kinetic, linear, ConvBiLSTM table and ensemble-warp)."),
    impacts: int = typer.Option(250, "--impacts", "-n", metavar="COUNT", min=1,
                                help="Impacts timed per path and latency setting."),
    latencies: list[str] = typer.Option(["low"], "--latency", metavar="low|high|SECONDS",
                                        callback=lambda values: [_latency(v) for v in values],
                                        help="Stream latency to time: 'low', 'high' or seconds (repeatable)."),
    max_latency: Optional[float] = typer.Option(None, "--max-latency", metavar="SECONDS", min=0.0, max=1.0, callback=finite,
                                                help="Longest buffer the stream may grow to after underflows "
                                                     "(0: never; default: the actuator's shipped max_latency)."),
    queue: Optional[float] = typer.Option(None, "--queue", metavar="SECONDS", min=0.0, max=2.0, callback=finite,
                                          help="The actuator's queue option: seconds queued at the PulseAudio server, "
                                               "impacts written over them; 0: the PortAudio stream of --latency "
                                               "(default: the shipped 'auto', a 0.15 s queue where a server answers)."),
    ahead: Optional[float] = typer.Option(None, "--ahead", metavar="SECONDS", min=0.002, max=0.5, callback=finite,
                                          help="With --queue: how far ahead of playback impacts are written "
                                               "(default: the actuator's shipped ahead)."),
    gap: float = typer.Option(0.55, "--gap", metavar="SECONDS", min=0.05, callback=finite,
                              help="Seconds between impacts (longer than one impact)."),
    device: str = typer.Option("default", "--device", "-d", metavar="DEVICE",
                               help="Sound output to time (its monitor must be the default input)."),
    seconds: float = typer.Option(2.0, "--seconds", metavar="SECONDS", min=0.1, callback=finite,
                                  help="Audio seconds mixed per capacity point."),
    voices: list[int] = typer.Option([1, 100, 1000, 4096], "--voices", metavar="COUNT",
                                     help="Impacts sounding at once (repeatable)."),
    recoveries: int = typer.Option(3, "--recoveries", metavar="COUNT", min=0,
                                   help="Stalls and restarts of a private sound server timed "
                                                                  "(0: skip)."),
    round_trips: int = typer.Option(200, "--round-trips", metavar="COUNT", min=1, help="Solenoid commands timed."),
):
    """Output-path timings: impact to first sample, mixer capacity, recovery, solenoid round trip.

    Latency: Engine.impact() (and an OSC datagram) to the first sample captured from the
    sound server's monitor, per model, through the effect's vibro-transducer spec, the
    engine's queue and worker, shaping, the limiters and the mixer; the floor is a ready
    click written into the same stream in the same run. The stream's underflows are set
    against the machine's own stalls over the same time (a probe per CPU, at real-time
    priority where permitted) and against the stream's late callbacks (gaps longer than
    its buffer, on its own clock). Where underflows lengthen the stream's buffer (up to
    max_latency), the latency table is given for each buffer. With a queue at the PulseAudio
    server (the shipped default where one answers; --queue) impacts are written over it, and
    --latency does not apply: give --queue 0 to time PortAudio streams.
    Needs a sound server whose
    default input records the output (the PulseAudio null sink of .ci/soundserver.sh).
    Capacity: the audio callback's wall time at the block sizes PortAudio uses here,
    against the block's period. Recovery: a private server (.ci/soundserver.sh) stalled
    for 1 s or killed and restarted under a playing actuator.
    """
    from .bench import output as bench

    paths = [Path(p) for p in (effects or DEFAULT_EFFECTS)]
    for p in paths:
        if not p.is_file():
            raise SignalError(f"{p}: no such effect file (run from the repository root, or name effect files)")
    typer.echo(f"## impact to first sample (ms), {len(paths)} models")
    for latency in latencies if queue == 0 else latencies[:1]:
        _latency_section(paths, impacts, latency, max_latency, device, gap, queue, ahead)

    typer.echo(f"\n## mixer capacity (one core, 48 kHz, limiter on; {seconds:g} s of audio per point)\n")
    typer.echo("| block (frames) | period ms | impacts at once | callback median ms | p99 | max | p99 / period "
               "| add() median us |\n|---:|---:|---:|---:|---:|---:|---:|---:|")
    for block in BLOCKS:
        period = block / 48000.0
        for n in voices:
            walls, adds = bench.block_wall_times(n, block, seconds=seconds)
            p99 = np.percentile(walls, 99)
            add = f"{np.median(adds) * 1e6:.1f}" if adds.size else "-"
            typer.echo(f"| {block} | {period * 1e3:.2f} | {n} | {np.median(walls) * 1e3:.4f} | {p99 * 1e3:.4f} "
                       f"| {walls.max() * 1e3:.4f} | {p99 / period:.3f} | {add} |")

    if recoveries:
        script = Path(".ci/soundserver.sh").resolve()
        typer.echo(f"\n## recovery after the sound server comes back ({recoveries} runs each)\n")
        if not script.is_file():
            typer.echo("skipped: .ci/soundserver.sh not found (run from the repository root)")
        else:
            typer.echo("| fault | detected (s, median) | back after its return (s): median | max | impacts heard after "
                       "| heard after play (ms, max) | cut off by the outage | outages after its return |"
                       "\n|---|---:|---:|---:|---:|---:|---:|---:|")
            from .actuator import AUTO_QUEUE_S

            faults = [(mode, queued, f"{label}; {stream}")
                      for queued, stream in ((AUTO_QUEUE_S, "queue at the server (the default)"), (0.0, "PortAudio stream"))
                      for mode, label in (("stall-resume", "server stopped 1 s, then continued"),
                                          ("restart", "server killed, then started again"))]
            for mode, queued, label in faults:
                runs = bench.recovery_runs(mode, recoveries, script=str(script), queue=queued, progress=say)
                back = [float(r["recovered_s"]) for r in runs if r.get("recovered_s", "never") != "never"]
                det = [float(r["detected_s"]) for r in runs if r.get("detected_s", "never") != "never"]
                heard = sum(int(r.get("heard", 0)) for r in runs)
                lost = sum(int(r.get("lost", 0)) for r in runs)
                after = [float(r["heard_after_s"]) * 1e3 for r in runs if r.get("heard_after_s", "never") != "never"]
                after = f"{max(after):.1f}" if after else "-"  # only a resumed server's capture clock is trusted
                # a restarted server may stall its first streams: further outages, each counted and come back from
                again = sum(int(r.get("outages_after_back", 0)) for r in runs) if mode == "restart" else "-"
                typer.echo(f"| {label} | {np.median(det):.3f} | {np.median(back):.3f} | {max(back):.3f} "
                           f"| {heard}/{len(runs)} (never back: {len(runs) - len(back)}) | {after} | {lost} | {again} |"
                           if back and det else f"| {label} | - | never | - | 0/{len(runs)} | - | {lost} | {again} |")

    typer.echo("\n## solenoid command round trip (pseudo-terminal + emulator)\n")
    try:
        from hapticfx_solenoid.bench.roundtrip import round_trips as solenoid_round_trips
    except ImportError:
        typer.echo("the solenoid plugin (hapticfx-solenoid) is not installed; skipped")
        return
    rt = solenoid_round_trips(round_trips)
    typer.echo("| path (ms) | median | p99 | min | max | lost | | |\n|---|---:|---:|---:|---:|---:|---|---|")
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


def bench_helmet(
    scene: Path = typer.Argument(Path("scenes/helmet_4.yaml"), help="A scene with a head of several actuators."),
    object: str = typer.Option("concrete-brick", metavar="OBJECT",
                               help="The object that falls (a key of the scene's effects)."),
    velocity: float = typer.Option(2.6, metavar="M/S", min=0.0, max=100.0, callback=finite,
                                  help="Its impact velocity (m/s)."),
    plot: Optional[Path] = typer.Option(None, metavar="PNG",
                                        help="Write the recorded impacts and their levels to this PNG."),
):
    """A head of several actuators on a multi-channel PulseAudio null sink: impacts on the first, second and last
    site and between the first two, recorded back, each channel's level against the layout's (dB)."""
    from hapticfx.errors import DeviceError
    from hapticfx.scene import load_scene

    from .bench import helmet

    layout = load_scene(scene).head
    if layout is None:
        raise DeviceError(f"{scene}: the scene has no head (several actuators) to measure")
    points = helmet.default_points(layout)
    try:
        cap = helmet.capture(scene, list(points.values()), object=object, velocity=velocity)
    except (RuntimeError, FileNotFoundError) as exc:
        raise DeviceError(f"bench helmet needs a running PulseAudio server with pactl and parec: {exc}") from None
    if len(cap.starts) != len(points):
        raise DeviceError(f"heard {len(cap.starts)} impact(s) of {len(points)}; engine: {json.dumps(cap.stats)}")
    typer.echo(f"{object} at {velocity:g} m/s through {scene} on a {cap.expected_db.shape[1]}-channel null sink; "
               "level per channel relative to the impact's energy over all channels")
    typer.echo(helmet.table(list(points), cap))
    losses = {k: v for out in cap.stats["outputs"].values() for k, v in out.get("losses", {}).items()}
    typer.echo(f"impacts the sound card took but could not play in full, per site: {losses or 'none'}")
    if plot is not None:
        helmet.plot(plot, list(points), cap, title=f"{scene.name}: {object} at {velocity:g} m/s, recorded from a "
                                                   f"{cap.expected_db.shape[1]}-channel null sink")
        typer.echo(f"wrote {plot}")
def bench_safety(
    runs: int = typer.Option(5, metavar="COUNT", min=1, max=100, help="times each case is run"),
    only: str = typer.Option("", metavar="NAME,...",
                             help="comma-separated case names to run (default: all; see --list)"),
    flood_s: float = typer.Option(10.0, metavar="SECONDS", min=0.5, max=120.0, callback=finite,
                                  help="seconds of the OSC flood into `hapticfx serve`"),
    list_cases: bool = typer.Option(False, "--list", help="list the cases and exit"),
) -> None:
    """Rerun every case of the safety probe (issue 31) and print, per case, the limit that applies, the
    largest peak and 50 ms RMS that reached the output over all runs, the windows over the limit, and the
    verdict. Sound-card cases play into the default PulseAudio sink and record its monitor; run them on a
    null sink (scripts/test.sh starts one), never on a sink with an actuator worn by someone."""
    from hapticfx.fuzz.probe import CORE_CASES

    from .bench.safety import SOUNDCARD_CASES, osc_flood

    cases = {**SOUNDCARD_CASES, "osc-flood": lambda: osc_flood(flood_s), **CORE_CASES}
    if list_cases:
        for name, fn in cases.items():
            typer.echo(f"{name:24} {(fn.__doc__ or '').strip().splitlines()[0] if fn.__doc__ else ''}")
        return
    chosen = [c.strip() for c in only.split(",") if c.strip()] or list(cases)
    unknown = [c for c in chosen if c not in cases]
    if unknown:
        raise HapticfxError(f"unknown case(s): {', '.join(unknown)}; --list shows them", key="--only")
    load = os.getloadavg()
    typer.echo(f"# hapticfx bench safety --runs {runs}: {platform.node()}, {os.cpu_count()} CPUs, "
               f"{datetime.now(timezone.utc):%Y-%m-%d}, load {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}")
    typer.echo("| case | limit | max peak | max 50 ms RMS | windows over | verdict |")
    typer.echo("|---|---|---:|---:|---:|---|")
    failed = 0
    for name in chosen:
        verdicts = []
        for k in range(runs):
            typer.echo(f"  {name}: run {k + 1}/{runs}", err=True)
            started = time.monotonic()
            verdicts.append(cases[name]())
            typer.echo(f"    {time.monotonic() - started:.1f} s: {verdicts[-1].note or 'done'}", err=True)
        v0 = verdicts[0]
        held = all(v.held for v in verdicts)
        failed += not held
        if all(v.refused for v in verdicts):
            typer.echo(f"| {v0.case} | {v0.limit} | - | - | - | refused {runs}/{runs}: {v0.refused} |")
            continue
        over = sum(v.windows_over for v in verdicts)
        samples = sum(v.samples_over for v in verdicts)
        verdict = f"held {runs}/{runs}" if held else (
            f"VIOLATED in {sum(not v.held for v in verdicts)}/{runs} ({samples} samples over the peak)")
        typer.echo(f"| {v0.case} | {v0.limit} | {max(v.peak for v in verdicts):.4f} | "
                   f"{max(v.rms for v in verdicts):.4f} | {over} | {verdict} |")
    typer.echo(f"tolerance: the sink's 16-bit step (1/32768) for the sound-card cases, 1e-6 otherwise; "
               f"load after: {os.getloadavg()[0]:.1f}")
    if failed:
        raise typer.Exit(1)


def add_commands(app: typer.Typer, bench: typer.Typer) -> None:
    app.command("devices")(devices)
    bench.command("output")(bench_output)
    bench.command("helmet")(bench_helmet)
    bench.command("safety")(bench_safety)
