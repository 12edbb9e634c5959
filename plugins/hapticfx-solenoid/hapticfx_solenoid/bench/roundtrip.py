"""Round-trip timing of the solenoid protocol: host pyserial <-> emulator process over a pty.

``hapticfx bench output`` calls :func:`round_trips`. ``python -m hapticfx_solenoid.bench.roundtrip``
prints the fuller table of docs/benchmarks.md#solenoid-details (with baselines from the same run).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

from contextlib import contextmanager

from hapticfx.errors import DeviceError


def round_trips(n: int) -> list[float]:
    """Seconds for each of ``n`` PING/PONG exchanges with an emulator in its own process.

    The emulator process answers on a pseudo-terminal; the host opens it with
    ``serial.Serial`` and handshakes first, so the figures are steady-state
    round trips (write, the emulator's select/read/reply, pyserial's read).
    """
    from ..link import SerialLink

    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    with emulator_process() as port:
        link = SerialLink(port, timeout_s=1.0)
        link.open()
        try:
            return _pings(link.request, n)
        finally:
            link.close()


def _pings(request, n: int) -> list[float]:
    times = []
    for _ in range(n):
        start = time.perf_counter()
        reply = request("PING")
        times.append(time.perf_counter() - start)
        if not reply.startswith("PONG "):
            raise DeviceError(f"emulator answered {reply!r} to PING")
    return times


@contextmanager
def emulator_process(*extra: str):
    """Run ``python -m hapticfx_solenoid.emulator`` in its own process; yields the port path."""
    with tempfile.TemporaryDirectory(prefix="hapticfx-solenoid-") as tmp:
        link_path = os.path.join(tmp, "port")
        proc = subprocess.Popen(
            [sys.executable, "-m", "hapticfx_solenoid.emulator", "--link", link_path, *extra],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
        )
        try:
            ready = proc.stdout.readline().strip()
            if ready != link_path:
                raise DeviceError(f"the emulator did not start (said {ready!r})")
            yield link_path
        finally:
            proc.terminate()
            proc.wait(timeout=5)


def _loop_echo(n: int) -> list[float]:
    """Baseline: pyserial's in-memory ``loop://`` port echoing the PING line (no pty, no emulator)."""
    import serial

    port = serial.serial_for_url("loop://", timeout=1.0)
    times = []
    for _ in range(n):
        start = time.perf_counter()
        port.write(b"PING\n")
        port.read_until(b"\n")
        times.append(time.perf_counter() - start)
    port.close()
    return times


def _thread_pings(n: int) -> list[float]:
    """The emulator in a thread of this process (what the 'emulator' port and the tests use)."""
    from ..emulator import PtyEmulator
    from ..link import SerialLink

    with PtyEmulator() as emulator:
        link = SerialLink(emulator.port, timeout_s=1.0)
        link.open()
        try:
            return _pings(link.request, n)
        finally:
            link.close()


def _plays(n: int) -> list[float]:
    """SolenoidActuator.play() of a 2 ms pulse, emulator process: planning + FIRE + reply."""
    import numpy as np

    from hapticfx.signal import Signal

    from ..actuator import SolenoidActuator

    pulse = Signal(np.r_[np.zeros(5), np.full(2, 0.8), np.zeros(20)], 1000.0)
    times = []
    with emulator_process() as port, SolenoidActuator(SolenoidActuator.Params(port=port)) as act:
        for _ in range(n):
            fired = act.report.fired
            start = time.perf_counter()
            act.play(pulse)
            times.append(time.perf_counter() - start)
            if act.report.fired != fired + 1:
                raise DeviceError(f"pulse not fired: {act.report}")
            time.sleep(0.003)
    return times


def _fault_times(kind: str, repeats: int) -> list[float]:
    """Seconds from open() to the DeviceError when the emulator process misbehaves."""
    from ..actuator import SolenoidActuator

    times = []
    for _ in range(repeats):
        with emulator_process("--fault", kind) as port:
            start = time.perf_counter()
            try:
                SolenoidActuator(SolenoidActuator.Params(port=port, timeout_s=0.5)).open()
            except DeviceError:
                times.append(time.perf_counter() - start)
            else:
                raise DeviceError(f"fault {kind!r} was not detected")
    return times


def _row(name: str, times: list[float], baseline: float | None) -> str:
    import statistics

    ordered = sorted(times)
    q1, median, q3 = statistics.quantiles(ordered, n=4) if len(ordered) > 1 else (ordered[0],) * 3
    p99 = ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]
    ratio = f"{median / baseline:.1f}x" if baseline else "-"
    return (f"| {name} | {len(times)} | {median * 1e6:.0f} | {q1 * 1e6:.0f}-{q3 * 1e6:.0f} | {p99 * 1e6:.0f} | "
            f"{ratio} |")


def main(n: int = 2000) -> None:
    loop = _loop_echo(n)
    base = sorted(loop)[len(loop) // 2]
    print("| what | n | median us | IQR us | p99 us | median / loop:// |")
    print("|---|---|---|---|---|---|")
    print(_row("pyserial loop:// echo (baseline)", loop, base))
    print(_row("PING/PONG, emulator process, pty", round_trips(n), base))
    print(_row("PING/PONG, emulator thread, pty", _thread_pings(n), base))
    print(_row("SolenoidActuator.play() (2 ms pulse), emulator process", _plays(n // 4), base))
    for kind in ("silent", "garbage", "babble", "close"):
        print(_row(f"open() -> DeviceError, fault {kind}", _fault_times(kind, 5), None))


if __name__ == "__main__":
    main()
