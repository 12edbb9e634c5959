"""``hapticfx bench serve`` and ``hapticfx bench scene``: the network bridge's latency and a scene's start-up.

Measurement only: nothing here runs when a scene plays an impact.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

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
