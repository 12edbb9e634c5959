"""A simulator loop that hands each collision to hapticfx, in-process or over OSC.

A fixed-step (1 ms) simulation of the paper's four objects falling from shelves
of different heights onto a head at 1.6 m; when one reaches the head its
impact velocity goes to hapticfx:

    python examples/python_simulator.py                       # in-process hapticfx.Engine, WAV output
    python examples/python_simulator.py --osc 127.0.0.1:9000  # to a running `hapticfx serve SCENE`

The loop never waits on haptics: ``Engine.impact`` and an OSC send both
return at once. (A full earthquake room with MuJoCo is in examples/earthquake/.)
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEAD_TOP_M = 1.6
G = 9.81
# object id -> (shelf height m, time it slips off the shelf s)
SHELVES = {"plastic-frame": (1.90, 0.10), "concrete-brick": (2.30, 0.35), "wood-beam": (2.50, 0.60), "steel-plate": (2.95, 0.80)}


def simulate(on_impact, *, duration_s: float = 2.0, dt: float = 1e-3, realtime: bool = False) -> list[tuple]:
    """Step the falling objects; call ``on_impact(object, velocity, at)`` when one reaches the head."""
    state = {o: [h, 0.0, False] for o, (h, _) in SHELVES.items()}  # height, vertical velocity, landed
    impacts, t, start = [], 0.0, time.perf_counter()
    while t < duration_s:
        for obj, (height, release) in SHELVES.items():
            s = state[obj]
            if s[2] or t < release:
                continue
            s[1] -= G * dt  # semi-implicit Euler
            s[0] += s[1] * dt
            if s[0] <= HEAD_TOP_M:
                s[2] = True
                impacts.append((obj, -s[1], t))
                on_impact(obj, -s[1], t)
        t += dt
        if realtime:
            time.sleep(max(0.0, t - (time.perf_counter() - start)))
    return impacts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, default=ROOT / "scenes" / "earthquake_room_kinetic.yaml")
    ap.add_argument("--device", default="wav:simulated_impacts.wav", help="'memory' or 'wav:PATH' (in-process only)")
    ap.add_argument("--osc", help="HOST:PORT of `hapticfx serve` instead of an in-process engine")
    ap.add_argument("--realtime", action="store_true", help="run the loop at wall-clock speed")
    args = ap.parse_args()

    if args.osc:
        try:
            from pythonosc.udp_client import SimpleUDPClient
        except ImportError:
            raise SystemExit("--osc sends with python-osc, which is not installed: pip install python-osc") from None

        host, port = args.osc.rsplit(":", 1)
        client = SimpleUDPClient(host, int(port))
        impacts = simulate(lambda o, v, t: client.send_message("/hapticfx/impact", [o, float(v), -1, float(t)]),
                           realtime=args.realtime)
        for o, v, t in impacts:
            print(f"t={t:.3f} s  sent {o} at {v:.2f} m/s")
        return

    from hapticfx.engine import Engine

    with Engine(args.scene, device=args.device) as engine:
        impacts = simulate(lambda o, v, t: engine.impact(o, v, at=t), realtime=args.realtime)
    stats = engine.stats()
    for p in engine.played():
        print(f"t={p.at:.3f} s  {p.object:15s} {p.velocity:.2f} m/s  peak {p.peak:.3f} "
              f"of full scale  ({p.latency_s * 1e3:.1f} ms from impact() to the actuator)")
    print(f"{len(impacts)} impacts: {stats['rendered']} rendered, {stats['failed']} failed, "
          f"{stats['dropped_queue_full']} dropped; free-fall check: "
          + ", ".join(f"{o} {v:.2f} (exact {math.sqrt(2 * G * (SHELVES[o][0] - HEAD_TOP_M)):.2f})" for o, v, _ in impacts))


if __name__ == "__main__":
    main()
