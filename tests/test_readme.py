"""Every shell command of README.md and docs/getting-started.md, run as a user would, in a temporary directory.

`hapticfx ...` and `python examples/...` run for real; `pip install` lines are checked against the
projects and extras they name (CI runs the installs themselves through scripts/install.sh); `bash
scripts/...` are what .ci/run runs; `mkdocs build` builds into the temporary directory.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCUMENTS = ("README.md", "docs/getting-started.md")


def commands(document: str) -> list[str]:
    """The shell commands of ``document``'s ```bash blocks (comments dropped, && chains split)."""
    blocks = re.findall(r"```bash\n(.*?)```", (REPO / document).read_text(), flags=re.S)
    out = []
    for block in blocks:
        for line in block.splitlines():
            line = line.split("  #")[0].strip()
            out += [part.strip() for part in line.split("&&") if part.strip()]
    return out


def readme_commands() -> list[str]:
    return [c for c in commands("README.md") if c.startswith("hapticfx ")]


ALL = [(doc, c) for doc in DOCUMENTS for c in commands(doc)]


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


@pytest.mark.parametrize("document, command", ALL, ids=[f"{d}: {c}" for d, c in ALL])
def test_every_documented_command_works(document, command, workdir):
    args = shlex.split(command)
    if args[0] == "hapticfx":
        r = run(command, workdir)
    elif args[:2] == ["pip", "install"]:
        target = args[-1]
        path, _, extras = target.partition("[")
        project = tomllib.loads((REPO / path / "pyproject.toml").read_text())["project"]
        for extra in filter(None, extras.rstrip("]").split(",")):
            assert extra in project.get("optional-dependencies", {}), f"{command}: no extra {extra!r}"
        return
    elif args[0] == "bash":
        assert args[1] in ("scripts/install.sh", "scripts/test.sh") and (REPO / args[1]).is_file()
        return  # .ci/run runs exactly these
    elif args[:2] == ["mkdocs", "build"]:
        pytest.importorskip("mkdocs")
        r = subprocess.run([sys.executable, "-m", "mkdocs", "build", *args[2:], "-d", str(workdir / "site")],
                           cwd=REPO, capture_output=True, text=True, timeout=300)
    elif args[0] == "python" and args[1] == "docs/gen_reference.py":
        r = subprocess.run([sys.executable, args[1]], cwd=REPO, capture_output=True, text=True, timeout=120)
    elif args[0] == "python" and args[1].startswith("examples/earthquake/"):
        pytest.importorskip("mujoco")
        out = workdir / args[args.index("--out") + 1]
        r = subprocess.run([sys.executable, str(REPO / args[1]), "--out", str(out), "--duration", "10"],
                           cwd=workdir, capture_output=True, text=True, timeout=300)
        assert (out / "earthquake.wav").is_file()
    else:
        pytest.fail(f"{document}: no test knows how to run {command!r}; teach test_readme.py")
    assert r.returncode == 0, f"{command}\n{r.stdout}\n{r.stderr}"


def test_getting_started_python_example_runs(workdir):
    code = re.findall(r"```python\n(.*?)```", (REPO / "docs/getting-started.md").read_text(), flags=re.S)
    assert code
    for block in code:
        r = subprocess.run([sys.executable, "-c", block], cwd=workdir, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
