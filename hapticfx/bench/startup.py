"""``hapticfx bench startup``: cold start of ``hapticfx play`` for effect files, in fresh processes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from ..errors import HapticfxError
from ..timing import Timing, ms, table

HEAVY = ("torch", "sounddevice", "serial", "scipy.signal", "matplotlib")
# Runs the CLI as `python -m hapticfx` would, then reports which heavy modules the run imported.
_PROBE = """
import atexit, json, runpy, sys
heavy = {heavy!r}
atexit.register(lambda: print("HAPTICFX-PROBE " + json.dumps([m for m in heavy if m in sys.modules]), file=sys.stderr))
sys.argv = ["hapticfx", *sys.argv[1:]]
runpy.run_module("hapticfx", run_name="__main__", alter_sys=True)
""".format(heavy=HEAVY)
DEFAULT_EFFECTS = ("effects/falling_brick.yaml", "effects/falling_brick_convbilstm.yaml",
                   "effects/falling_brick_linear.yaml", "effects/falling_brick_kinetic.yaml")


# As a user's machine runs it: Python may cache compiled modules (a warm-up run writes them).
_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def _run(args: list[str]) -> tuple[float, list[str]]:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _PROBE, *args], capture_output=True, text=True, env=_ENV)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        last = proc.stderr.strip().splitlines()
        raise HapticfxError(f"`hapticfx {' '.join(args)}` failed: {last[-1] if last else proc.returncode}")
    line = [x for x in proc.stderr.splitlines() if x.startswith("HAPTICFX-PROBE ")][-1]
    return wall, json.loads(line.split(" ", 1)[1])


def startup(
    effects: Optional[list[Path]] = typer.Argument(None, help="Effect files to play (default: the falling brick's "
                                                  "ConvBiLSTM, ensemble-warp, linear and kinetic-energy effects)."),
    baseline: Path = typer.Option(Path("effects/falling_brick_linear.yaml"), "--baseline", metavar="EFFECT",
                                  help="The effect every ratio is taken against (measured in the same run)."),
    repeats: int = typer.Option(9, "--repeats", metavar="COUNT", min=3,
                                help="Fresh processes per effect, taken in turns."),
):
    """Cold start: wall time of `hapticfx play EFFECT --device wav:FILE` in a fresh process, from the interpreter's
    start to the WAV on disk, against floors (python alone, `import hapticfx`) and a baseline
    effect; and which heavy modules each run imported."""
    paths = [Path(p) for p in (effects or DEFAULT_EFFECTS)]
    if baseline not in paths:
        paths.append(baseline)
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise HapticfxError(f"effect file(s) not found: {', '.join(missing)} (run from the repository root or "
                            "name the files)")
    with tempfile.TemporaryDirectory() as tmp:
        cases = {"python -c pass": None, "python -c 'import hapticfx'": None}
        cases.update({f"play {p}": ["play", str(p), "--device", f"wav:{Path(tmp) / 'out.wav'}"] for p in paths})
        walls: dict[str, list[float]] = {c: [] for c in cases}
        imported: dict[str, set[str]] = {c: set() for c in cases}
        for args in cases.values():  # warm-up: compiled modules cached, files in the page cache
            if args is not None:
                _run(args)
        for i in range(repeats):  # in turns, so that a change in machine load falls on every case alike
            for label, args in cases.items():
                if args is None:
                    code = "pass" if label.endswith("pass") else "import hapticfx"
                    t0 = time.perf_counter()
                    subprocess.run([sys.executable, "-c", code], check=True, env=_ENV)
                    walls[label].append(time.perf_counter() - t0)
                    continue
                wall, heavy = _run(args)
                walls[label].append(wall)
                imported[label].update(heavy)
            typer.echo(f"run {i + 1}/{repeats}", err=True)
    base = Timing(tuple(walls[f"play {baseline}"])).median
    rows = []
    for label, samples in walls.items():
        t = Timing(tuple(samples))
        rows.append([label, ms(t.median), ms(float(np.min(samples))), ms(t.iqr), f"{t.median / base:.2f}",
                     ", ".join(sorted(imported[label])) or "-"])
    typer.echo(f"fresh process (`{Path(sys.executable).name} -m hapticfx ...`, compiled modules cached after a "
               f"warm-up run), {repeats} runs each, in turns; ratio against `play {baseline}`")
    typer.echo(table(["what", "median ms", "min ms", "IQR ms", "x baseline", "heavy modules imported"], rows))


def register(bench: typer.Typer) -> None:
    bench.command("startup")(startup)
