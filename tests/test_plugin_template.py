"""The third-party plugin template (examples/hapticfx-example-actuator) installs with pip,
shows in `hapticfx plugins`, and plays an effect through it.

It is installed with this interpreter's pip into a folder of its own (``pip install
--target``), which the commands below put on ``PYTHONPATH``: numpy, scipy and hapticfx
itself come from the environment the tests run in, a virtual environment included (a
venv nested in one with --system-site-packages would see the base interpreter's
packages instead), and nothing is downloaded (--no-build-isolation: the build uses this
environment's setuptools, which the test extra requires). It is installed from a copy:
building it writes build files next to its sources.
"""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from hapticfx.shaping import FADE_IN_S

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "hapticfx-example-actuator"

pytestmark = pytest.mark.slow


def run(*args, env=None, cwd=None, check=True) -> subprocess.CompletedProcess:
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True, env=env, cwd=cwd, timeout=120)
    if check and done.returncode != 0:
        raise AssertionError(f"{args} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The example plugin installed into a folder of its own; its sources (a copy)."""
    base = tmp_path_factory.mktemp("template")
    target, source = base / "site", base / "src"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    run(sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-build-isolation",
        "--no-deps", "--target", target, source)
    return target, source


def read_rows(path: Path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def clean_env(target: Path | None = None, **extra) -> dict:
    """This environment without HAPTICFX_PLUGINS; with ``target`` (the plugin's folder) on PYTHONPATH."""
    env = {k: v for k, v in os.environ.items() if k != "HAPTICFX_PLUGINS"}
    if target is not None:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(target), env.get("PYTHONPATH")) if p)
    env.update(extra)
    return env


def test_installs_into_its_folder_only(installed):
    target, _ = installed
    found = run(sys.executable, "-m", "hapticfx", "plugins", env=clean_env(target)).stdout
    line = next(l for l in found.splitlines() if " csv-logger " in l)
    assert line.split() == ["actuator", "csv-logger", "csvlog", "hapticfx-example-actuator", "0.1.0"]
    outside = run(sys.executable, "-m", "hapticfx", "plugins", env=clean_env()).stdout
    assert "csv-logger" not in outside


def test_allow_list_controls_loading(installed):
    target, _ = installed
    only_solenoid = run(sys.executable, "-m", "hapticfx", "plugins",
                        env=clean_env(target, HAPTICFX_PLUGINS="solenoid")).stdout
    assert "csv-logger" not in only_solenoid
    only_it = run(sys.executable, "-m", "hapticfx", "plugins", env=clean_env(target, HAPTICFX_PLUGINS="csvlog")).stdout
    assert "csv-logger" in only_it and "solenoid" not in only_it


def test_plays_an_effect_through_it(installed, tmp_path):
    target, _ = installed
    effect = tmp_path / "brick_logged.yaml"
    effect.write_text(textwrap.dedent("""\
        name: brick-logged
        object: concrete-brick
        velocity_mps: 3.8
        model: {type: kinetic-energy, pulse_ms: 30}
        actuator:
          type: csv-logger
          path: impacts.csv
          rate_hz: 1000
          gain: 1.0
    """))
    done = run(sys.executable, "-m", "hapticfx", "play", effect, "--velocity", "4.2", env=clean_env(target), cwd=tmp_path)
    assert "CSV log" in done.stdout
    # and through the Python API, to compare the log with what the pipeline sent
    check = textwrap.dedent(f"""
        import numpy as np
        from hapticfx.pipeline import Pipeline
        from hapticfx_csvlog.actuator import read_log
        with Pipeline.from_effect({str(effect)!r}, device={str(tmp_path / 'api.csv')!r}) as p:
            d = p.impact(velocity=4.2)
        row, = read_log({str(tmp_path / 'api.csv')!r})
        assert np.array_equal(row["samples"], d.output.samples)
        print(row["peak"], row["above_half_s"], row["n_samples"])
    """)
    peak, above, n = run(sys.executable, "-c", check, env=clean_env(target)).stdout.split()
    # the 30 ms pulse, less the first half of shaping's 2 ms fade-in (below half scale)
    assert float(above) == pytest.approx(0.030 - FADE_IN_S / 2) and int(n) > 0 and float(peak) > 0



def test_cli_log_matches_a_render(installed, tmp_path):
    target, _ = installed
    effect = tmp_path / "e.yaml"
    effect.write_text("name: e\nobject: steel-plate\nvelocity_mps: 5.24\nmodel: {type: kinetic-energy, pulse_ms: 20}\n"
                      "actuator: {type: csv-logger, path: out.csv, gain: 1.0}\n")
    run(sys.executable, "-m", "hapticfx", "play", effect, env=clean_env(target))
    run(sys.executable, "-m", "hapticfx", "play", effect, "--device", tmp_path / "second.csv", env=clean_env(target))
    first, = read_rows(tmp_path / "out.csv")
    second, = read_rows(tmp_path / "second.csv")
    assert first["samples"] == second["samples"]
    samples = np.array(first["samples"].split(), dtype=float)
    assert float(first["above_half_s"]) == pytest.approx(0.020 - FADE_IN_S / 2)  # as above
    assert float(first["peak"]) == np.abs(samples).max() > 0
    assert not list(tmp_path.glob(".*.part"))  # no temporary file left behind


def test_the_examples_own_tests_pass_where_it_is_installed(installed):
    target, source = installed
    done = run(sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", source / "tests", env=clean_env(target),
               cwd=source)
    assert " passed" in done.stdout
