"""Start and stop the PulseAudio null sink of .ci/soundserver.sh for the sound-card tests."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
SCRIPT = REPO / ".ci" / "soundserver.sh"


def worker_runtime_dir() -> str | None:
    """Under pytest-xdist, this worker's own server (``$HAPTICFX_XDG-gw1``...): a recording of the sink's monitor
    must not hear what another worker plays at the same moment. None in a run without workers."""
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    return f"{os.environ.get('HAPTICFX_XDG', '/tmp/hapticfx-xdg')}-{worker}" if worker else None


def start_soundserver(runtime_dir: str | None = None) -> str:
    """Run .ci/soundserver.sh (idempotent); returns the XDG_RUNTIME_DIR of that server."""
    missing = [t for t in ("pulseaudio", "pactl", "pacat") if shutil.which(t) is None]
    if missing:
        pytest.skip(f"PulseAudio is not installed ({', '.join(missing)} missing): "
                    "apt-get install -y libportaudio2 pulseaudio pulseaudio-utils libasound2-plugins")
    env = dict(os.environ)
    if runtime_dir:
        env["HAPTICFX_XDG"] = runtime_dir
    done = subprocess.run(["bash", str(SCRIPT)], env=env, capture_output=True, text=True, timeout=30)
    if done.returncode != 0:
        pytest.fail(f"{SCRIPT} failed ({done.returncode}): {done.stderr.strip()}")
    return done.stdout.strip().splitlines()[-1]


def stop_soundserver(runtime_dir: str) -> None:
    """Stop the server (and its keep-alive) that start_soundserver started in ``runtime_dir``."""
    from hapticfx_soundcard.bench.virtualserver import stop

    stop(runtime_dir)
