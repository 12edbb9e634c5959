"""``hapticfx bench flood``: `hapticfx serve` under a sustained OSC flood; memory and accounting.

The server runs as its own process (``python -m hapticfx serve``) exactly as a
user starts it. A sender paces valid ``/hapticfx/impact`` datagrams at a fixed
rate for a fixed time; the server's resident memory is read from
``/proc/PID/status`` once a second. At the end the server is stopped with
SIGTERM and its final counters (the JSON line ``serve`` prints) are checked:
every datagram sent is either lost by the kernel before the bridge read it, or
received, and every one received is accepted or dropped by a reason; every
impact accepted is played, failed (by kind), dropped, cancelled or pending.
"""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from ..errors import HapticfxError
from ..osc import encode_impact


def _rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS")


def run(scene: Path, *, seconds: float, rate: float, device: str | None, echo) -> dict:
    """Flood one ``serve`` process; returns the measurements (see the module docstring)."""
    cmd = [sys.executable, "-m", "hapticfx", "serve", str(scene), "--port", "0"]
    if device:
        cmd += ["--device", device]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    stderr_lines: list[str] = []
    reader = threading.Thread(target=lambda: stderr_lines.extend(proc.stderr), daemon=True)
    reader.start()
    first = proc.stdout.readline()
    found = re.search(r"listening on ([\d.]+):(\d+) .*: (.*)\)$", first.strip())
    if not found:
        proc.kill()
        proc.wait()
        reader.join(timeout=5)
        said = [line.strip() for line in (*stderr_lines, first) if line.strip()]
        raise HapticfxError(f"serve did not start: {said[-1].removeprefix('hapticfx: error: ') if said else 'no output'}")
    addr = (found.group(1), int(found.group(2)))
    objects = [o.strip() for o in found.group(3).split(",")]
    time.sleep(1.0)  # settled
    rss = [_rss_mib(proc.pid)]
    start_rss = rss[0]
    echo(f"serve pid {proc.pid} on {addr[0]}:{addr[1]}, {len(objects)} objects, RSS {start_rss:.1f} MiB; "
         f"flooding {rate:g}/s for {seconds:g} s")
    rng = np.random.default_rng(0)
    datagrams = [encode_impact(objects[i % len(objects)], float(v))
                 for i, v in enumerate(rng.uniform(2.45, 5.2, 4096))]
    sent = 0
    tick = 0.01
    t0 = time.monotonic()
    next_rss = t0 + 1.0
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
        while True:
            now = time.monotonic()
            elapsed = now - t0
            if elapsed >= seconds:
                break
            due = int(min(elapsed + tick, seconds) * rate)
            while sent < due:
                client.sendto(datagrams[sent % len(datagrams)], addr)
                sent += 1
            if now >= next_rss:
                rss.append(_rss_mib(proc.pid))
                next_rss += 1.0
                if len(rss) % 10 == 0:
                    echo(f"  {elapsed:.0f} s: {sent} sent, RSS {rss[-1]:.1f} MiB")
            time.sleep(max(0.0, t0 + (due / rate) - time.monotonic()))
    time.sleep(2.0)  # the queues drain
    end_rss = _rss_mib(proc.pid)
    rss.append(end_rss)
    proc.send_signal(signal.SIGTERM)
    out = proc.stdout.read()  # stderr is the reader thread's
    proc.wait(timeout=60)
    reader.join(timeout=5)
    final = json.loads(out.strip().splitlines()[-1])
    return {"sent": sent, "seconds": seconds, "rate": rate, "rss_start": start_rss, "rss_max": max(rss),
            "rss_end": end_rss, "final": final, "returncode": proc.returncode,
            "stderr_lines": len(stderr_lines), "stderr_tail": [s.rstrip() for s in stderr_lines[-3:]]}


def accounting(r: dict) -> list[tuple[str, int]]:
    """The balance of one run: each line of it, and what is left unaccounted (must be 0)."""
    bridge, engine = r["final"]["bridge"], r["final"]["engine"]
    received = bridge["received"]
    dropped = {k: v for k, v in bridge["dropped"].items() if v}
    losses: dict[str, int] = {}
    for out in engine["outputs"].values():
        for k, v in out.get("losses", {}).items():
            losses[k] = losses.get(k, 0) + v
    return [
        ("sent", r["sent"]),
        ("lost before the bridge read them (kernel)", r["sent"] - received),
        ("received by the bridge", received),
        *[(f"  dropped by the bridge: {k}", v) for k, v in dropped.items()],
        ("  accepted (queued by the engine)", bridge["accepted"]),
        ("    played", engine["rendered"]),
        *[(f"    failed: {k}", v) for k, v in engine["errors"].items()],
        ("    cancelled at close", engine["cancelled"]),
        ("    pending at close", engine["pending"]),
        *[(f"      of those played, the device lost: {k}", v) for k, v in losses.items()],
        ("unaccounted: received - accepted - bridge drops",
         received - bridge["accepted"] - sum(bridge["dropped"].values())),
        ("unaccounted: accepted - played - failed - cancelled - pending",
         bridge["accepted"] - engine["rendered"] - engine["failed"] - engine["cancelled"] - engine["pending"]),
        ("unaccounted: bridge queue_full - engine queue full",
         bridge["dropped"].get("queue_full", 0) - engine["dropped_queue_full"]),
    ]
