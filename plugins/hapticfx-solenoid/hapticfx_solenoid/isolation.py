"""``hapticfx bench isolation``: does a silent solenoid board delay another output?

A scene with two outputs, as in a simulator that drives a vibro-transducer and
a solenoid at once: a WAV file (the falling brick, kinetic-energy model) and the
solenoid on an emulator in its own process. Impacts go to both; the WAV output's
latency (``Engine.impact`` to the actuator holding the samples) is compared
between a healthy board and one that stops answering after the handshake (every
command then times out), in alternating runs of the same process, and
``Engine.close()`` is timed after each.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from .bench import emulator_process

SCENE = """\
name: isolation
actuators:
  helmet: {{type: wav, path: {wav}, rate_hz: 48000, overwrite: true}}
  coil: {{type: solenoid, port: {port}, reset_wait_s: 0.0, limits: {{max_on_s: 0.05}}}}
effects:
  concrete-brick:
    actuator: helmet
    inline: {{name: brick, object: concrete-brick, model: {{type: kinetic-energy}}, actuator: {{type: memory}}}}
  steel-plate:
    actuator: coil
    inline: {{name: plate, object: steel-plate, model: {{type: kinetic-energy, pulse_ms: 30}}, actuator: {{type: memory}}}}
"""


def run_once(silent: bool, impacts: int, interval_s: float) -> dict:
    """One engine on a healthy or silent board: WAV latencies (s), close time (s), the coil's counters."""
    from hapticfx.engine import Engine

    extra = ("--fault", "silent", "--fault-after", "2") if silent else ()  # PING and STATUS are answered
    with tempfile.TemporaryDirectory() as tmp, emulator_process(*extra) as port:
        scene = Path(tmp) / "scene.yaml"
        scene.write_text(SCENE.format(wav=Path(tmp) / "out.wav", port=port))
        engine = Engine(scene)
        rng = np.random.default_rng(1)
        for i in range(impacts):
            engine.impact("concrete-brick", float(rng.uniform(2.45, 5.2)))
            if i % 4 == 0:  # a pulse every 4th impact: within the coil's duty limit when it answers
                engine.impact("steel-plate", float(rng.uniform(2.45, 5.2)))
            time.sleep(interval_s)
        t0 = time.perf_counter()
        stats = engine.close()
        closing = time.perf_counter() - t0
        wav = [p.latency_s for p in engine.played() if p.output == "actuators.helmet"]
    return {"wav": np.array(wav), "close_s": closing, "coil": stats["outputs"]["actuators.coil"],
            "helmet": stats["outputs"]["actuators.helmet"]}


def table(runs: dict[str, list[dict]]) -> str:
    """Markdown rows per board state, with the WAV latency ratio against the healthy board."""
    lines = ["| board | WAV latency median ms | p99 | max | x healthy (median) | close() s (max) "
             "| WAV played | coil played / failed / cancelled |", "|---|---:|---:|---:|---:|---:|---:|---|"]
    base = np.median(np.concatenate([r["wav"] for r in runs["healthy"]]))
    for state, rs in runs.items():
        wav = np.concatenate([r["wav"] for r in rs]) * 1e3
        coil = [sum(r["coil"][k] for r in rs) for k in ("rendered", "failed", "cancelled")]
        lines.append(f"| {state} | {np.median(wav):.3f} | {np.percentile(wav, 99):.3f} | {wav.max():.3f} "
                     f"| {np.median(wav) / (base * 1e3):.2f} | {max(r['close_s'] for r in rs):.2f} "
                     f"| {sum(r['helmet']['rendered'] for r in rs)} | {coil[0]} / {coil[1]} / {coil[2]} |")
    return "\n".join(lines)
