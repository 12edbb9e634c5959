"""Starting and stopping a private PulseAudio null-sink server (the recipe of .ci/soundserver.sh).

For the fault tests and the recovery benchmark, which stall, kill and restart a
server of their own rather than the one other programs play into.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path


def start(runtime_dir: str, script: str | Path) -> None:
    """Run ``script`` (.ci/soundserver.sh) for a server in ``runtime_dir``; idempotent."""
    env = {**os.environ, "HAPTICFX_XDG": str(runtime_dir)}
    done = subprocess.run(["bash", str(script)], env=env, capture_output=True, text=True, timeout=60)
    if done.returncode != 0:
        raise RuntimeError(f"{script} failed ({done.returncode}): {done.stderr.strip()}")


def stop(runtime_dir: str, *, timeout_s: float = 5.0) -> None:
    """Stop the server (and its keep-alive) started in ``runtime_dir``, even a stopped (SIGSTOP) one, and wait
    until both are gone: an exiting daemon still writes into ``runtime_dir``, which its caller then removes."""
    stopping = []
    for pid_file, program in (("pulse/pid", b"pulseaudio"), ("keepalive.pid", b"pacat")):
        try:
            pid = int((Path(runtime_dir) / pid_file).read_text().strip())
            if _is(pid, program):  # not a recycled pid
                os.kill(pid, signal.SIGCONT)
                os.kill(pid, signal.SIGTERM)
                stopping.append((pid, program))
        except (OSError, ValueError):
            pass  # already gone
    deadline = time.monotonic() + timeout_s
    for pid, program in stopping:
        while _is(pid, program):
            if time.monotonic() > deadline:
                os.kill(pid, signal.SIGKILL)
                break
            time.sleep(0.01)


def _is(pid: int, program: bytes) -> bool:
    """Is ``pid`` a live ``program``? (A zombie has an empty command line.)"""
    try:
        return program in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False
