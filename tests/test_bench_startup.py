"""Benchmark commands that time the path users run: `bench startup` (cold start) and `bench render` (per stage)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_startup_table_names_floors_baseline_and_heavy_imports(tmp_path):
    torchy = tmp_path / "direct.yaml"
    torchy.write_text((REPO / "effects" / "falling_brick_convbilstm.yaml").read_text().replace(
        "interpolator: convbilstm", "interpolator: convbilstm\n  interpolator_options: {cache: false}"))
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "startup", "effects/falling_brick.yaml",
                        str(torchy), "--repeats", "3"], cwd=REPO, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in r.stdout.splitlines() if line.startswith("| ") and "median ms" not in line}
    assert rows["play effects/falling_brick_linear.yaml"][3] == "1.00"  # the default baseline joins the run
    assert rows["play effects/falling_brick.yaml"][4] == "-"
    assert "torch" in rows[f"play {torchy}"][4]
    assert {"python -c pass", "python -c 'import hapticfx'"} <= set(rows)


def test_missing_effects_are_named():
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "startup", "nope.yaml", "--repeats", "3"],
                       cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 2 and "effect file(s) not found: nope.yaml" in r.stderr


def test_bench_render_times_each_stage_with_the_effects_own_actuator():
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "render", "effects/falling_brick.yaml",
                        "effects/families/tapping.yaml", "--repeats", "5"], cwd=REPO, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    assert "| effects/falling_brick.yaml" in r.stdout and "vibro-transducer 48000 Hz" in r.stdout
    assert "haptuator 48000 Hz" in r.stdout and "| model" in r.stdout and "| limiter" in r.stdout
    assert "| head: spread" in r.stdout and "| render + head" in r.stdout
