"""The README's commands, run as a user would (the install step is what CI itself runs)."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def readme_commands() -> list[str]:
    blocks = re.findall(r"```bash\n(.*?)```", (REPO / "README.md").read_text(), flags=re.S)
    out = []
    for block in blocks:
        for line in block.splitlines():
            line = line.split("  #")[0].strip()
            for part in line.split("&&"):
                part = part.strip()
                if part.startswith("hapticfx "):
                    out.append(part)
    return out


def run(command: str, cwd: Path, **env):
    args = shlex.split(command)
    expanded = []
    for a in args[1:]:
        expanded += [str(p.relative_to(cwd)) for p in sorted(cwd.glob(a))] if "*" in a else [a]
    return subprocess.run([sys.executable, "-m", "hapticfx", *expanded], cwd=cwd, capture_output=True,
                          text=True, env={**os.environ, **env}, timeout=240)


@pytest.fixture
def workdir(tmp_path):
    (tmp_path / "effects").symlink_to(REPO / "effects")
    return tmp_path


def test_readme_has_the_main_command():
    assert "hapticfx play effects/falling_brick.yaml" in readme_commands()


@pytest.mark.parametrize("command", readme_commands())
def test_readme_command_runs(workdir, command):
    r = run(command, workdir)
    assert r.returncode == 0, f"{command}\n{r.stdout}\n{r.stderr}"


def test_main_command_on_a_headless_machine_writes_wav_and_png(workdir):
    """No sound server reachable: one line, exit 0, the impact in a named WAV and PNG."""
    env = {k: v for k, v in os.environ.items() if k != "XDG_RUNTIME_DIR"}
    env["PULSE_SERVER"] = "unix:/nonexistent/hapticfx-test"
    r = subprocess.run([sys.executable, "-m", "hapticfx", "play", "effects/falling_brick.yaml"], cwd=workdir,
                       capture_output=True, text=True, env=env, timeout=240)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("no output device (")
    wav = workdir / "hapticfx-falling-brick-3.80mps.wav"
    assert f"wrote the impact to {wav.name} and hapticfx-falling-brick-3.80mps.png instead" in lines[0]
    assert wav.stat().st_size > 10_000 and (workdir / "hapticfx-falling-brick-3.80mps.png").stat().st_size > 10_000
