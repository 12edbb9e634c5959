"""Built-in scene plugin of hapticfx: ``hapticfx serve``, ``bench serve`` and ``bench scene``.

Typer and the engine are imported inside ``register_commands`` and the
commands, so that building the registry stays cheap.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ..errors import DeviceError
from ..hookspecs import hookimpl

# A physics-only scene for benchmarks: the paper's four objects, kinetic-energy model, one shared output.
_BENCH_OBJECTS = ("plastic-frame", "concrete-brick", "wood-beam", "steel-plate")


def bench_scene_file(directory: Path, model: dict, *, port: int = 0) -> Path:
    """Write a scene with the paper's four objects on one 48 kHz memory actuator, using ``model``."""
    import yaml

    scene = {
        "name": "bench",
        "actuators": {"helmet": {"type": "memory", "rate_hz": 48000.0}},
        "effects": {
            o: {"actuator": "helmet", "inline": {"name": o, "object": o, "model": model, "actuator": {"type": "memory"}}}
            for o in _BENCH_OBJECTS
        },
        "events": {"osc": {"host": "127.0.0.1", "port": port, "rate_hz": 0}},
    }
    path = directory / f"scene-{model['type']}-{model.get('interpolator', '')}.yaml".replace("--", "-")
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    return path


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


def serve_scene(scene_path: Path, *, host: str | None, port: int | None, device: str | None,
                stats_every: float, duration: float | None, echo, allow_remote: bool = False,
                secret: str | None = None, warn=None) -> dict:
    """Run the OSC bridge on a scene until SIGINT/SIGTERM (or ``duration``); returns the final counters.

    ``warn`` (default: ``echo``) receives the warning printed when the bridge listens beyond loopback."""
    from ..engine import Engine
    from ..osc import OscBridge
    from ..scene import OscSettings, load_scene
    from ..stopsignals import StopSignals

    scene = load_scene(scene_path)
    osc = scene.osc or OscSettings()
    with StopSignals() as stop:
        with Engine(scene, device=device) as engine:
            bridge = OscBridge(engine.submit, engine.objects, host=host or osc.host,
                               port=osc.port if port is None else port, max_datagram=osc.max_datagram,
                               rate_hz=osc.rate_hz, burst=osc.burst, allow_remote=allow_remote, secret=secret)
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
                bridge_stats = bridge.stats()
            engine_stats = engine.close()
    return {"bridge": bridge_stats, "engine": engine_stats}


def bench_serve(*, impacts: int, interval_s: float, scene_path: Path | None, echo) -> str:
    """Latency from a datagram's arrival (and from its sending) to the actuator holding the samples."""
    import socket
    import threading

    import numpy as np

    from ..engine import Engine
    from ..osc import OscBridge, encode_impact
    from ..timing import Timing, ms, table

    with tempfile.TemporaryDirectory() as tmp:
        path = scene_path or bench_scene_file(Path(tmp), {"type": "kinetic-energy"})
        rng = np.random.default_rng(0)
        done = threading.Semaphore(0)
        with Engine(path, device="memory", on_played=lambda p: done.release()) as engine:
            objects = engine.objects
            rates = sorted({p.actuator.spec.rate_hz for p in engine._pipelines.values()})
            plan = [(objects[i % len(objects)], float(rng.uniform(2.42, 5.24))) for i in range(impacts)]
            bridge = OscBridge(engine.submit, objects, port=0, rate_hz=0)
            with bridge, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
                addr = bridge.address
                sends = {
                    "direct": lambda obj, v: engine.impact(obj, v),
                    "osc": lambda obj, v: client.sendto(encode_impact(obj, v), addr),
                }
                runs = {"direct": [], "osc": []}
                # 20 warm-up impacts (first-use imports, caches), then both paths interleaved
                # (alternating which goes first) so that both see the same machine load.
                warm = plan[:20]
                for k, (obj, v) in enumerate(warm + plan):
                    for mode in (("direct", "osc") if k % 2 else ("osc", "direct")):
                        sent = time.perf_counter()
                        sends[mode](obj, v)
                        if not done.acquire(timeout=5):
                            raise RuntimeError(f"impact {k} ({mode}) was not played within 5 s: {engine.stats()}")
                        if k >= len(warm):
                            runs[mode].append((sent, engine.played()[-1]))
                        time.sleep(interval_s)
                counters = bridge.stats()
            echo(f"{impacts} impacts per path played; bridge {json.dumps(counters)}")
    direct, osc = runs["direct"], runs["osc"]
    t_direct = Timing(tuple(p.played - p.received for _, p in direct))
    t_arrival = Timing(tuple(p.played - p.received for _, p in osc))
    t_send = Timing(tuple(p.played - s for s, p in osc))
    t_render = Timing(tuple(p.played - p.started for _, p in osc + direct))
    rows = [
        ["Engine.impact() in-process -> actuator (baseline)", ms(t_direct.median), ms(t_direct.p99), ms(t_direct.iqr), "1.00"],
        ["serve: datagram arrival -> actuator", ms(t_arrival.median), ms(t_arrival.p99), ms(t_arrival.iqr),
         f"{t_arrival.median / t_direct.median:.2f}"],
        ["serve: client sendto() -> actuator", ms(t_send.median), ms(t_send.p99), ms(t_send.iqr),
         f"{t_send.median / t_direct.median:.2f}"],
        ["  of which render + limiter + play on the worker (both paths)", ms(t_render.median), ms(t_render.p99), ms(t_render.iqr),
         f"{t_render.median / t_direct.median:.2f}"],
    ]
    drops = _bench_drop_costs(engine)
    return (f"{impacts} impacts per path, one at a time ({interval_s * 1e3:.0f} ms apart, paths interleaved), "
            f"{'scene ' + str(scene_path) if scene_path else 'kinetic-energy scene, 4 objects'} -> memory actuator "
            f"at {', '.join(f'{r / 1e3:g}' for r in rates)} kHz\n"
            + table(["path", "median ms", "p99 ms", "IQR ms", "x baseline"], rows)
            + "\n\ncost of classifying one datagram that is dropped (OscBridge.handle, no socket; 2000 each)\n"
            + drops)


def _bench_drop_costs(engine) -> str:
    """Per-datagram cost of each drop path: what a flood costs the server."""
    import random

    from ..osc import OscBridge, TokenBucket, encode_impact
    from ..timing import measure, table

    rng = random.Random(0)
    cases = {
        "rate_limited (bucket empty)": (b"/hapticfx/impact\x00" * 3, TokenBucket(1e-9, 1)),
        "oversize (1500 B)": (rng.randbytes(1500), None),
        "not_osc (random 200 B)": (b"\x01" + rng.randbytes(199), None),
        "wrong_address": (encode_impact("x", 1.0).replace(b"/hapticfx/impact", b"/hapticfx/impacx"), None),
        "unknown_object": (encode_impact("anvil", 3.8), None),
    }
    rows = []
    bridge = OscBridge(engine.submit, engine.objects, port=0, rate_hz=0)
    try:
        for label, (data, bucket) in cases.items():
            bridge.bucket = bucket or TokenBucket(0, 1)
            bridge.bucket.take()
            t = measure(lambda: bridge.handle(data, 0.0), repeat=2000, warmup=50)
            rows.append([label, f"{t.median * 1e6:.1f}", f"{t.p99 * 1e6:.1f}", f"{1 / t.median:,.0f}"])
        assert bridge.stats()["accepted"] == 0
    finally:
        bridge.stop()
    return table(["datagram", "median us", "p99 us", "datagrams/s at the median"], rows)


_STARTUP_PROBE = """
import json, resource, sys, time
t0 = time.perf_counter()
from hapticfx.engine import Engine
e = Engine(sys.argv[1], device="memory")
t1 = time.perf_counter()
e.impact(e.objects[0], 3.8)
s = e.close()
t2 = time.perf_counter()
print(json.dumps({"build_s": t1 - t0, "first_impact_s": t2 - t1, "failed": s["failed"],
                  "maxrss_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                  "torch": "torch" in sys.modules, "sounddevice": "sounddevice" in sys.modules}))
"""

SCENE_MODELS = (
    ("physics (kinetic-energy)", {"type": "kinetic-energy"}),
    ("data-driven, linear", {"type": "data-driven", "interpolator": "linear"}),
    ("data-driven, ensemble", {"type": "data-driven", "interpolator": "ensemble"}),
    ("neural (data-driven, convbilstm, table)", {"type": "data-driven", "interpolator": "convbilstm"}),
)


def bench_scene(*, runs: int, echo, neural_weights: Path | None = None) -> str:
    """Start-up time and peak memory of a fresh process that builds a scene and plays one impact.

    ``neural_weights``: a convbilstm checkpoint directory for the neural row
    (default: the weights the neural plugin ships, if any).
    """
    import numpy as np

    from ..timing import Timing, ms, table

    def probe(path: Path) -> tuple[float, dict | str]:
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", _STARTUP_PROBE, str(path)], capture_output=True, text=True,
                              env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            return wall, proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else f"exit {proc.returncode}"
        return wall, json.loads(proc.stdout.strip().splitlines()[-1])

    with tempfile.TemporaryDirectory() as tmp:
        scenes = {}
        for label, model in SCENE_MODELS:
            if neural_weights is not None and model.get("interpolator") == "convbilstm":
                model = {**model, "interpolator_options": {"weights": str(Path(neural_weights).resolve())}}
                label += f" [{neural_weights}]"
            scenes[label] = bench_scene_file(Path(tmp), model)
        results: dict[str, list] = {label: [] for label in scenes}
        for i in range(runs):  # scenes interleaved run by run, so that all see the same machine load
            for label, path in list(scenes.items()):
                wall, info = probe(path)
                if isinstance(info, str):
                    echo(f"skipped {label}: {info}")
                    del scenes[label], results[label]
                    continue
                results[label].append((wall, info))
            echo(f"run {i + 1}/{runs} done")
    rows, base = [], None
    for label, res in results.items():
        t = Timing(tuple(w for w, _ in res))
        rss = float(np.median([r["maxrss_kb"] / 1024 for _, r in res]))
        base = base or (t.median, rss)
        info = res[-1][1]
        failed = sum(r["failed"] for _, r in res)
        rows.append([label, ms(t.median), ms(t.iqr), ms(float(np.median([r["build_s"] for _, r in res]))),
                     ms(float(np.median([r["first_impact_s"] for _, r in res]))), f"{rss:.0f}",
                     f"{t.median / base[0]:.2f}", f"{rss / base[1]:.2f}", "yes" if info["torch"] else "no",
                     "ok" if failed == 0 else f"{failed} failed"])
    return (f"fresh process: build the 4-object scene (memory actuator), play one impact, exit; {runs} runs each\n"
            + table(["scene", "process wall median ms", "IQR ms", "import + build ms", "first impact ms", "peak RSS MiB", "x physics time", "x physics RSS",
                     "torch imported", "impact"], rows))


@hookimpl
def register_commands(app, bench):
    import typer

    from ..progress import say

    @app.command("serve")
    def serve(
        scene: Path = typer.Argument(..., help="Scene file (YAML)."),
        host: str = typer.Option(None, help="Address to bind (default: the scene's events.osc.host, else 127.0.0.1)."),
        port: int = typer.Option(None, min=0, max=65535, help="UDP port (default: the scene's events.osc.port, else 9000; 0: any free)."),
        device: str = typer.Option(None, help="Replace every actuator: 'memory' or 'wav:PATH' (one file per output)."),
        stats_every: float = typer.Option(0.0, min=0.0, help="Print the counters as JSON every this many seconds (0: only at exit)."),
        duration: float = typer.Option(None, min=0.0, help="Stop after this many seconds (default: until Ctrl-C or SIGTERM)."),
        allow_remote: bool = typer.Option(False, "--allow-remote", help="Listen on an address other machines can "
                                          "reach (--host 0.0.0.0, or the scene's host); refused without this flag."),
        secret_file: Path = typer.Option(None, help="A file whose first line is a shared secret (16-128 letters, "
                                         "digits, '_', '-'): other machines must then send /<secret>/hapticfx/impact."),
    ):
        """Receive impacts over OSC/UDP (docs/protocol.md) and render them on the scene's actuators.

        Listens on 127.0.0.1 unless told otherwise; an address other machines can reach needs --allow-remote
        and prints a warning."""
        secret = read_secret(secret_file) if secret_file is not None else None
        out = serve_scene(scene, host=host, port=port, device=device, stats_every=stats_every, duration=duration,
                          echo=lambda line: typer.echo(line, err=False) or sys.stdout.flush(),
                          allow_remote=allow_remote, secret=secret, warn=lambda line: typer.echo(line, err=True))
        typer.echo(json.dumps(out))
        engine = out["engine"]
        if engine.get("close_errors") or engine["failed"]:
            lost = "; ".join(f"{k}: {v}" for k, v in {**engine["errors"], **engine.get("close_errors", {})}.items())
            raise DeviceError(f"{engine['failed']} impact(s) failed and {len(engine.get('close_errors', {}))} "
                              f"output(s) could not be finished ({lost})")

    @bench.command("serve")
    def bench_serve_cmd(
        impacts: int = typer.Option(300, min=10, help="Impacts per row."),
        interval_ms: float = typer.Option(5.0, min=0.0, help="Pause after each impact is played (ms)."),
        scene: Path = typer.Option(None, help="Scene to serve (default: a 4-object kinetic-energy scene)."),
    ):
        """Latency from `serve` receiving an impact to its samples reaching the actuator (median, p99)."""
        typer.echo(bench_serve(impacts=impacts, interval_s=interval_ms / 1e3, scene_path=scene,
                               echo=say))

    @bench.command("flood")
    def bench_flood_cmd(
        scene: Path = typer.Argument(Path("scenes/earthquake_room.yaml"), help="Scene to serve."),
        seconds: float = typer.Option(60.0, min=1.0, help="How long to flood."),
        rate: float = typer.Option(3500.0, min=1.0, help="Impacts sent per second."),
        device: str = typer.Option(None, help="Replace every actuator ('memory', 'wav:PATH'); default: the scene's own."),
    ):
        """`hapticfx serve` under a sustained OSC flood: resident memory over time, and every impact accounted for."""
        from .flood import accounting, run

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
        repeats: int = typer.Option(5, "--repeats", min=1, help="Fresh processes per scene."),
        neural_weights: Path = typer.Option(None, help="convbilstm checkpoint directory (default: the shipped weights)."),
    ):
        """Start-up time and peak memory of a physics-only scene against data-driven and neural ones."""
        typer.echo(bench_scene(runs=repeats, neural_weights=neural_weights, echo=say))
