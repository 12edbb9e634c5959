"""Built-in scene plugin of hapticfx: ``hapticfx serve``, and the wiring of ``bench serve``, ``bench flood`` and ``bench scene``.

Typer and the engine are imported inside ``register_commands`` and the
commands, so that building the registry stays cheap.
"""

from __future__ import annotations

import json
import sys
import time
from contextlib import ExitStack
from pathlib import Path

from ..errors import DeviceError
from ..hookspecs import hookimpl


def read_secret(path: Path) -> str:
    """The OSC shared secret: the first line of ``path``."""
    from ..osc import check_secret

    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise DeviceError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DeviceError(f"{path}: cannot read the secret ({getattr(exc, 'strerror', None) or exc})") from None
    return check_secret(lines[0].strip() if lines else "", source=f"{path}: the first line")


def _remote_warning(address: tuple[str, int], secret: str | None) -> str:
    where = f"{address[0]}:{address[1]}"
    if secret is None:
        return (f"hapticfx: warning: listening on {where}, beyond this machine, with no secret: anyone who can "
                f"reach this UDP port can play impacts on the scene's actuators (docs/protocol.md; --secret-file)")
    return (f"hapticfx: warning: listening on {where}, beyond this machine: other machines must address "
            f"/<secret>/hapticfx/impact; the secret travels in clear text, so it keeps out senders that do not "
            f"know it, not ones that can read the network (docs/protocol.md)")


def _played_line(p) -> str:
    """One played impact as a JSON line (``serve --log``)."""
    def rounded(v):
        return None if v is None else [round(c, 6) for c in v]

    return json.dumps({"object": p.object, "velocity": round(p.velocity, 6), "at": p.at, "point": rounded(p.point),
                       "normal": rounded(p.normal), "output": p.output, "peak": round(p.peak, 6),
                       "duration_s": p.duration_s, "latency_ms": round(p.latency_s * 1e3, 3)})


def serve_scene(scene_path: Path, *, host: str | None, port: int | None, device: str | None,
                stats_every: float, duration: float | None, echo, allow_remote: bool = False,
                secret: str | None = None, warn=None, log_path: Path | None = None, overwrite: bool = False) -> dict:
    """Run the OSC bridge on a scene until SIGINT/SIGTERM (or ``duration``); returns the final counters.

    ``warn`` (default: ``echo``) receives the warning printed when the bridge listens beyond loopback;
    ``log_path``: each played impact is written there as a JSON line as it is played. ``overwrite``: replace
    an output file (``device`` ``wav:PATH``, ``log_path``) that exists and hapticfx did not write."""
    import threading

    from ..actuators.files import check_overwrite
    from ..engine import Engine
    from ..osc import OscBridge
    from ..scene import OscSettings, load_scene
    from ..stopsignals import StopSignals

    scene = load_scene(scene_path)
    osc = scene.osc or OscSettings()
    if log_path is not None:
        check_overwrite(log_path, force=overwrite)
    log_file = None
    lock = threading.Lock()

    def write(playback) -> None:
        line = _played_line(playback)
        with lock:
            log_file.write(line + "\n")
            log_file.flush()

    with StopSignals() as stop, ExitStack() as closing:
        closing.callback(lambda: log_file is not None and log_file.close())  # after the engine's last impact
        with Engine(scene, device=device, on_played=write if log_path else None, overwrite=overwrite) as engine:
            bridge = OscBridge(engine.submit, engine.objects, host=host or osc.host,
                               port=osc.port if port is None else port, max_datagram=osc.max_datagram,
                               rate_hz=osc.rate_hz, burst=osc.burst, allow_remote=allow_remote, secret=secret)
            if log_path is not None:  # once the outputs opened and the port is bound: a refusal leaves it as it was
                try:
                    log_file = open(log_path, "w", encoding="utf-8")  # noqa: SIM115
                except BaseException:
                    bridge.stop()
                    raise
            with bridge:
                if bridge.remote:
                    (warn or echo)(_remote_warning(bridge.address, secret))
                h, p = bridge.address
                echo(f"listening on {h}:{p} (OSC /hapticfx/impact; scene {scene.name!r}: {', '.join(engine.objects)})")
                started = time.monotonic()
                while stop.received is None:
                    left = None if duration is None else duration - (time.monotonic() - started)
                    if left is not None and left <= 0:
                        break
                    waits = [w for w in (stats_every or None, left) if w is not None]
                    if stop.wait(min(waits) if waits else None):
                        break
                    if stats_every:
                        echo(json.dumps({"bridge": bridge.stats(), "engine": engine.stats()}))
                bridge.stats()  # the kernel's drop count, read while the socket is open
            bridge_stats = bridge.stats()  # the receiver has stopped: its counts and the engine's agree
            engine_stats = engine.close()
    return {"bridge": bridge_stats, "engine": engine_stats}




@hookimpl
def register_commands(app, bench):
    import typer

    from ..cli.options import finite
    from ..progress import say

    @app.command("serve")
    def serve(
        scene: Path = typer.Argument(..., help="Scene file (YAML)."),
        host: str = typer.Option(None, metavar="ADDRESS",
                                 help="Address to bind (default: the scene's events.osc.host, else 127.0.0.1)."),
        port: int = typer.Option(None, metavar="PORT", min=0, max=65535,
                                 help="UDP port (default: the scene's events.osc.port, else 9000; 0: any free)."),
        device: str = typer.Option(None, metavar="DEVICE",
                                   help="Replace every actuator: 'memory', 'wav:PATH' or 'csv:PATH' (one file per "
                                        "output, each impact at its time)."),
        stats_every: float = typer.Option(0.0, metavar="SECONDS", min=0.0, callback=finite,
                                          help="Print the counters as JSON every this many seconds (0: only at exit)."),
        duration: float = typer.Option(None, metavar="SECONDS", min=0.001, callback=finite,
                                       help="Stop after this many seconds (default: until Ctrl-C or SIGTERM)."),
        allow_remote: bool = typer.Option(False, "--allow-remote", help="Listen on an address other machines can "
                                          "reach (--host 0.0.0.0, or the scene's host); refused without this flag."),
        secret_file: Path = typer.Option(None, metavar="FILE",
                                         help="A file whose first line is a shared secret (16-128 letters, "
                                         "digits, '_', '-'): other machines must then send /<secret>/hapticfx/impact."),
        log: Path = typer.Option(None, metavar="FILE",
                                 help="Write each played impact (object, velocity, at, point, normal, output, "
                                 "peak, latency) to this file as it is played, one JSON line each."),
        force: bool = typer.Option(False, "--force", help="Replace a --device wav:/csv: file or --log file that "
                                   "exists and hapticfx did not write (its own are replaced anyway); without it "
                                   "serve refuses before it listens."),
    ):
        """Receive impacts over OSC/UDP (docs/protocol.md) and render them on the scene's actuators.

        Listens on 127.0.0.1 unless told otherwise; an address other machines can reach needs --allow-remote
        and prints a warning."""
        secret = read_secret(secret_file) if secret_file is not None else None
        if log is not None and not log.resolve().parent.is_dir():
            raise DeviceError(f"--log {log}: directory {log.resolve().parent} does not exist")
        out = serve_scene(scene, host=host, port=port, device=device, stats_every=stats_every, duration=duration,
                          echo=lambda line: typer.echo(line, err=False) or sys.stdout.flush(),
                          allow_remote=allow_remote, secret=secret, warn=lambda line: typer.echo(line, err=True),
                          log_path=log, overwrite=force)
        typer.echo(json.dumps(out))
        engine = out["engine"]
        if engine.get("close_errors") or engine["failed"]:
            lost = "; ".join(f"{k}: {v}" for k, v in {**engine["errors"], **engine.get("close_errors", {})}.items())
            raise DeviceError(f"{engine['failed']} impact(s) failed and {len(engine.get('close_errors', {}))} "
                              f"output(s) could not be finished ({lost})")

    @bench.command("serve")
    def bench_serve_cmd(
        impacts: int = typer.Option(300, metavar="COUNT", min=10, help="Impacts per row."),
        interval_ms: float = typer.Option(5.0, metavar="MS", min=0.0, callback=finite,
                                          help="Pause after each impact is played (ms)."),
        scene: Path = typer.Option(None, metavar="SCENE",
                                   help="Scene to serve (default: a 4-object kinetic-energy scene)."),
    ):
        """Latency from `serve` receiving an impact to its samples reaching the actuator (median, p99)."""
        from ..bench.serve import bench_serve

        typer.echo(bench_serve(impacts=impacts, interval_s=interval_ms / 1e3, scene_path=scene,
                               echo=say))

    @bench.command("flood")
    def bench_flood_cmd(
        scene: Path = typer.Argument(Path("scenes/earthquake_room.yaml"), help="Scene to serve."),
        seconds: float = typer.Option(60.0, metavar="SECONDS", min=1.0, callback=finite, help="How long to flood."),
        rate: float = typer.Option(3500.0, metavar="PER_SECOND", min=1.0, callback=finite, help="Impacts sent per second."),
        device: str = typer.Option(None, metavar="DEVICE",
                                   help="Replace every actuator ('memory', 'wav:PATH'); default: the scene's own."),
    ):
        """`hapticfx serve` under a sustained OSC flood: resident memory over time, and every impact accounted for."""
        from ..bench.flood import accounting, run

        r = run(scene, seconds=seconds, rate=rate, device=device, echo=say)
        where = f"--device {device}" if device else "the scene's own actuators"
        typer.echo(f"{r['sent']} impacts in {seconds:g} s ({rate:g}/s) to `hapticfx serve {scene}` ({where})\n")
        typer.echo("| resident memory (MiB) | start | max | end | end - start |\n|---|---:|---:|---:|---:|")
        typer.echo(f"| serve process | {r['rss_start']:.1f} | {r['rss_max']:.1f} | {r['rss_end']:.1f} "
                   f"| {r['rss_end'] - r['rss_start']:+.1f} |\n")
        typer.echo("| impacts | count |\n|---|---:|")
        for label, n in accounting(r):
            typer.echo(f"| {label} | {n} |")
        typer.echo(f"\nserve exited {r['returncode']}; {r['stderr_lines']} line(s) on its stderr"
                   + (f", last: {r['stderr_tail'][-1]!r}" if r["stderr_tail"] else ""))

    @bench.command("scene")
    def bench_scene_cmd(
        repeats: int = typer.Option(5, "--repeats", metavar="COUNT", min=1, help="Fresh processes per scene."),
        neural_weights: Path = typer.Option(None, metavar="DIR",
                                            help="convbilstm checkpoint directory (default: the shipped weights)."),
    ):
        """Start-up time and peak memory of a physics-only scene against data-driven and neural ones."""
        from ..bench.serve import bench_scene

        typer.echo(bench_scene(runs=repeats, neural_weights=neural_weights, echo=say))
