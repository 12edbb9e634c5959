"""How late the machine wakes a sleeping thread, per CPU: the floor under stream underflows.

An output stream underflows when the thread that feeds it is not run for longer than
the buffer holds. On a virtual machine a CPU can be lost below user space for more
than a 'low' buffer (11-12 ms on the 2-vCPU project machine, measured with
``cyclictest`` on an idle machine), and no program inside can prevent that. To tell
such underflows from ours, ``hapticfx bench output`` runs this probe beside its sends:
one process per CPU, pinned to it, at the highest real-time priority where the system
permits (then only the kernel and the host can delay it: not the sound server's
real-time threads, our Python threads or the GIL). Each wakes every ``period`` and
notes every wake-up later than ``threshold``. The host's own account of the time it
took each CPU away (``steal`` in ``/proc/stat``) is read at both ends; on the project
machine it accounts for part of the stalls only (docs/benchmarks.md).

Run as ``python -m hapticfx_soundcard.bench.stallprobe CPU PERIOD_S THRESHOLD_S``: it prints
``ready POLICY`` once running and, when its stdin closes, one JSON line with the
stalls (monotonic start time, seconds the thread was not run).
"""

from __future__ import annotations

import json
import os
import select
import subprocess
import sys
import time
from dataclasses import dataclass, field

from hapticfx.errors import HapticfxError


@dataclass(frozen=True)
class Stall:
    """A wake-up that came late: the CPU, when the sleep began (``time.monotonic``), how long it lasted."""

    cpu: int
    start: float
    seconds: float

    @property
    def end(self) -> float:
        return self.start + self.seconds


@dataclass
class StallProbe:
    """One probe process per CPU for the length of a ``with`` block; ``stalls`` is filled on exit.

    ``policy`` says how the probes ran: ``fifo`` (real-time, the highest priority) or
    ``other`` (the normal scheduler, where the system refuses real-time priority; then
    busy threads of this machine count as stalls too). ``steal_s`` is the time the host
    says it took each CPU away over the same span (empty where the system does not say).
    """

    period_s: float = 0.001
    threshold_s: float = 0.002
    stalls: list[Stall] = field(default_factory=list)
    policy: str = ""
    started: float = 0.0  # time.monotonic() when every probe was running
    seconds: float = 0.0
    steal_s: dict[int, float] = field(default_factory=dict)  # per probed CPU
    _procs: list = field(default_factory=list)
    _cpus: list[int] = field(default_factory=list)
    _steal: dict[int, float] = field(default_factory=dict)

    def __enter__(self) -> "StallProbe":
        self._cpus = sorted(os.sched_getaffinity(0))
        for cpu in self._cpus:
            proc = subprocess.Popen([sys.executable, "-m", __name__, str(cpu), repr(self.period_s),
                                     repr(self.threshold_s)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
            self._procs.append(proc)
            ready = proc.stdout.readline().split()
            if ready[:1] != ["ready"]:
                self.__exit__()
                raise HapticfxError(f"the machine-stall probe on CPU {cpu} did not start "
                                    f"(python -m {__name__} {cpu} ... printed {' '.join(ready) or 'nothing'!r})")
            self.policy = ready[1]
        self.started = time.monotonic()
        self._steal = _steal_s()
        return self

    def __exit__(self, *exc) -> bool:
        self.seconds = time.monotonic() - self.started if self.started else 0.0
        now = _steal_s()
        self.steal_s = {cpu: now[cpu] - was for cpu, was in self._steal.items()
                        if cpu in now and cpu in self._cpus}
        for proc in self._procs:
            out, _ = proc.communicate(timeout=10)  # closes its stdin: the probe reports and ends
            for line in out.splitlines():
                if line.startswith("{"):
                    found = json.loads(line)
                    self.stalls += [Stall(found["cpu"], start, seconds) for start, seconds in found["stalls"]]
        self._procs.clear()
        self.stalls.sort(key=lambda s: s.start)
        return False

    def everywhere(self, stall: Stall) -> bool:
        """Whether every other CPU probed stalled at some time during ``stall`` too: the whole
        machine paused, not one CPU busy with something else."""
        others = (set(self._cpus) | {s.cpu for s in self.stalls}) - {stall.cpu}
        return bool(others) and all(
            any(s.cpu == cpu and s.start < stall.end and stall.start < s.end for s in self.stalls) for cpu in others)

    def before(self, t: float, *, within_s: float) -> Stall | None:
        """The longest stall that ended in the ``within_s`` seconds before (or at) ``t``."""
        near = [s for s in self.stalls if t - within_s <= s.end <= t + self.period_s]
        return max(near, key=lambda s: s.seconds, default=None)


def _steal_s() -> dict[int, float]:
    """Seconds of ``steal`` per CPU since boot (``/proc/stat``); empty where there is no such file."""
    try:
        lines = open("/proc/stat").read().splitlines()
    except OSError:
        return {}
    tick = os.sysconf("SC_CLK_TCK")
    out = {}
    for line in lines:
        fields = line.split()
        if fields[0].startswith("cpu") and fields[0][3:].isdigit() and len(fields) > 8:
            out[int(fields[0][3:])] = int(fields[8]) / tick
    return out


def _run(cpu: int, period_s: float, threshold_s: float) -> None:
    os.sched_setaffinity(0, {cpu})
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(os.sched_get_priority_max(os.SCHED_FIFO)))
        policy = "fifo"
    except (PermissionError, OSError):
        policy = "other"
    print("ready", policy, flush=True)
    stalls = []
    while True:
        t0 = time.monotonic()
        closed = select.select([sys.stdin], [], [], period_s)[0]  # sleeps one period; returns early at EOF
        slept = time.monotonic() - t0
        if closed:
            break
        if slept - period_s > threshold_s:
            stalls.append((t0, slept))
    if policy == "fifo":
        # Reporting and exiting took the two probes 31-40 ms; at this priority that kept every other
        # thread off their CPUs, the audio being timed included (an underflow at 5 of 6 exits).
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    print(json.dumps({"cpu": cpu, "policy": policy, "stalls": stalls}), flush=True)


if __name__ == "__main__":
    _run(int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]))
