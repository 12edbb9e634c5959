"""``hapticfx bench render``: render latency per model and start-up time of ``play``."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import typer
import yaml

from ..errors import HapticfxError
from ..timing import Timing, ms, table

# (label, model section): every model an effect can use without training.
MODELS = (
    ("kinetic-energy", {"type": "kinetic-energy"}),
    ("data-driven/linear", {"type": "data-driven", "interpolator": "linear"}),
    ("data-driven/ensemble", {"type": "data-driven", "interpolator": "ensemble"}),
    ("data-driven/convbilstm (table)", {"type": "data-driven", "interpolator": "convbilstm"}),
    ("data-driven/convbilstm (direct)", {"type": "data-driven", "interpolator": "convbilstm",
                                        "interpolator_options": {"cache": False}}),
    ("contact", {"type": "contact"}),
)


# Start-up of `play` for a physics-only effect, the linear data-driven one and the paper's method.
STARTUP = [(label, model) for label, model in MODELS
           if label in ("kinetic-energy", "data-driven/linear", "data-driven/ensemble", "data-driven/convbilstm (table)")]


def _effect(tmp: Path, label: str, model: dict) -> Path:
    path = tmp / f"{label.replace('/', '-').replace(' ', '')}.yaml"
    path.write_text(yaml.safe_dump({
        "name": "bench", "object": "concrete-brick", "velocity_mps": 3.8, "model": model,
        "actuator": {"type": "memory", "rate_hz": 48000.0},
    }))
    return path


def _time_command(cmd: list[str], repeat: int) -> Timing:
    """Wall time of a command in a fresh process, ``repeat`` runs."""
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
        out.append(time.perf_counter() - t0)
    return Timing(tuple(out))


def render(
    repeat: int = typer.Option(200, help="Timed renders per model."),
    startup_runs: int = typer.Option(7, help="Timed runs of `hapticfx play` in a fresh process."),
):
    """Render latency per model (median, p99; velocity between recorded ones, 48 kHz memory actuator)
    and the start-up time of `hapticfx play` for a physics-only effect."""
    from ..pipeline import Pipeline

    pipelines = {}
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        for label, model in MODELS:
            try:
                pipelines[label] = Pipeline.from_effect(_effect(tmp, label, model))
            except HapticfxError as exc:
                typer.echo(f"skipped {label}: {exc}", err=True)
        # Every render gets a fresh velocity (no model cache can answer it), and the models take
        # turns, so a change in machine load falls on all of them alike.
        rng = np.random.default_rng(0)
        velocities = rng.uniform(2.45, 5.2, size=repeat + 5)
        times = {label: [] for label in pipelines}
        for i, v in enumerate(velocities):
            for label, pipeline in pipelines.items():
                t0 = time.perf_counter()
                pipeline.render(velocity=float(v))
                if i >= 5:  # the first five are warm-up
                    times[label].append(time.perf_counter() - t0)
        base = Timing(tuple(times["kinetic-energy"])).median
        rows = []
        for label, samples in times.items():
            t = Timing(tuple(samples))
            rows.append([label, ms(t.median), ms(t.p99), ms(t.iqr), f"{t.median / base:.2f}"])
        typer.echo(f"render latency per impact (model + shaping to 48 kHz + limiter), {repeat} renders per model, "
                   "interleaved; velocities uniform in [2.45, 5.2] m/s, a new one each render")
        typer.echo(table(["model", "median ms", "p99 ms", "IQR ms", "x kinetic-energy"], rows))
        imp = _time_command([sys.executable, "-c", "import hapticfx"], startup_runs)
        startup = [["python -c 'import hapticfx'", ms(imp.median), ms(imp.p99), "1.00"]]
        for label, model in STARTUP:
            if label not in pipelines:
                continue
            effect = _effect(tmp, f"startup-{label}", model)
            t = _time_command([sys.executable, "-m", "hapticfx", "play", str(effect), "--device", "memory"],
                              startup_runs)
            startup.append([f"hapticfx play <{label} effect> --device memory", ms(t.median), ms(t.p99),
                            f"{t.median / imp.median:.2f}"])
    typer.echo(f"\nstart-up to the end of one impact, fresh process, {startup_runs} runs")
    typer.echo(table(["what", "median ms", "p99 ms", "x python -c 'import hapticfx'"], startup))


def register(bench: typer.Typer) -> None:
    bench.command("render")(render)
