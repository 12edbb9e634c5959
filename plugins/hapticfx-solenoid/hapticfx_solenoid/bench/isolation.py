"""``hapticfx bench isolation``: does a silent solenoid board delay another output?

A scene with two outputs, as in a simulator that drives a vibro-transducer and
a solenoid at once: a WAV file (the falling brick, kinetic-energy model) and the
solenoid on an emulator in its own process. Impacts go to both; the WAV output's
latency (``Engine.impact`` to the actuator holding the samples) is compared
between a healthy board and one that stops answering after the handshake (every
command then times out), in alternating runs of the same process, and
``Engine.close()`` is timed after each. A third run in each turn has no board at
all (the WAV output alone): the floor, which tells a silent board delaying the
WAV output from a healthy board's own work competing with it for the CPUs.
"""

from __future__ import annotations

import tempfile
import time
from contextlib import nullcontext
from pathlib import Path

import numpy as np

from .roundtrip import emulator_process

BOARDS = {"none": "none (the WAV output alone)", "healthy": "healthy", "silent": "silent after the handshake"}
HELMET = "  helmet: {{type: wav, path: {wav}, rate_hz: 48000, overwrite: true}}\n"
COIL = "  coil: {{type: solenoid, port: {port}, reset_wait_s: 0.0, limits: {{max_on_s: 0.05}}}}\n"
BRICK = """\
  concrete-brick:
    actuator: helmet
    inline: {{name: brick, object: concrete-brick, model: {{type: kinetic-energy}}, actuator: {{type: memory}}}}
"""
PLATE = """\
  steel-plate:
    actuator: coil
    inline: {{name: plate, object: steel-plate, model: {{type: kinetic-energy, pulse_ms: 30}}, actuator: {{type: memory}}}}
"""


def run_once(board: str, impacts: int, interval_s: float) -> dict:
    """One engine with no board, a healthy or a silent one (a key of ``BOARDS``): WAV latencies (s),
    close time (s), the outputs' counters (``coil`` None without a board)."""
    from hapticfx.engine import Engine

    if board not in BOARDS:
        raise ValueError(f"board must be one of {', '.join(BOARDS)}; got {board!r}")
    extra = ("--fault", "silent", "--fault-after", "2") if board == "silent" else ()  # PING and STATUS answered
    with tempfile.TemporaryDirectory() as tmp, \
            (nullcontext() if board == "none" else emulator_process(*extra)) as port:
        scene = Path(tmp) / "scene.yaml"
        coil, plate = ("", "") if port is None else (COIL, PLATE)
        text = f"name: isolation\nactuators:\n{HELMET}{coil}effects:\n{BRICK}{plate}"
        scene.write_text(text.format(wav=Path(tmp) / "out.wav", port=port))
        engine = Engine(scene)
        rng = np.random.default_rng(1)
        for i in range(impacts):
            engine.impact("concrete-brick", float(rng.uniform(2.45, 5.2)))
            if i % 4 == 0:  # a pulse every 4th impact: within the coil's duty limit when it answers
                v = float(rng.uniform(2.45, 5.2))  # drawn without a board too: the same velocities for the brick
                if port is not None:
                    engine.impact("steel-plate", v)
            time.sleep(interval_s)
        t0 = time.perf_counter()
        stats = engine.close()
        closing = time.perf_counter() - t0
        wav = [p.latency_s for p in engine.played() if p.output == "actuators.helmet"]
    return {"wav": np.array(wav), "close_s": closing, "coil": stats["outputs"].get("actuators.coil"),
            "helmet": stats["outputs"]["actuators.helmet"]}


def table(runs: dict[str, list[dict]]) -> str:
    """Markdown rows per board (keys of ``BOARDS``), with the WAV latency's median against the healthy
    board's and against the WAV output alone."""
    lines = ["| board | WAV latency median ms | p99 | max | x healthy (median) | x WAV alone (median) "
             "| close() s (max) | WAV played | coil played / failed / cancelled |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    median = {board: np.median(np.concatenate([r["wav"] for r in rs])) for board, rs in runs.items()}
    for board, rs in runs.items():
        wav = np.concatenate([r["wav"] for r in rs]) * 1e3
        coil = " / ".join(str(sum(r["coil"][k] for r in rs)) for k in ("rendered", "failed", "cancelled")) \
            if rs[0]["coil"] is not None else "-"
        ratios = " | ".join(f"{median[board] / median[b]:.2f}" if b in median else "-" for b in ("healthy", "none"))
        lines.append(f"| {BOARDS[board]} | {np.median(wav):.3f} | {np.percentile(wav, 99):.3f} | {wav.max():.3f} "
                     f"| {ratios} | {max(r['close_s'] for r in rs):.2f} "
                     f"| {sum(r['helmet']['rendered'] for r in rs)} | {coil} |")
    return "\n".join(lines)
