"""`hapticfx play` with the solenoid effect shipped in this plugin, end to end in a
subprocess: the in-process emulator, an emulator process with a fault, a missing port."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from hapticfx_solenoid.bench.roundtrip import emulator_process

EFFECT = Path(__file__).resolve().parents[1] / "effects" / "falling_brick_solenoid.yaml"


def play(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hapticfx", "play", str(EFFECT), *args],
                          capture_output=True, text=True, timeout=60)


def pulse_of(stdout: str) -> tuple[int, int]:
    ms, duty = re.search(r"last pulse (\d+) ms at PWM (\d+)/255", stdout).groups()
    return int(ms), int(duty)


def test_play_on_the_emulator_and_stronger_impacts_push_harder():
    slow, fast = play("--device", "emulator", "-v", "2.5"), play("--device", "emulator", "-v", "5.2")
    assert slow.returncode == 0 and fast.returncode == 0, slow.stderr + fast.stderr
    (slow_ms, slow_duty), (fast_ms, fast_duty) = pulse_of(slow.stdout), pulse_of(fast.stdout)
    assert slow_ms == fast_ms == 30  # Eq. 11's pulse length from the effect
    assert slow_duty < fast_duty  # Eq. 10: amplitude grows with kinetic energy


def test_faulty_board_is_one_line_and_exit_2():
    with emulator_process("--fault", "garbage") as port:
        done = play("--device", port)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert "not the hapticfx solenoid protocol" in done.stderr


def test_missing_port_is_one_line_and_exit_2():
    done = play("--device", "/dev/ttyACM-hapticfx-missing")
    assert done.returncode == 2 and done.stderr.startswith("hapticfx: error: /dev/ttyACM-hapticfx-missing: cannot open")


def test_bench_isolation_a_silent_board_loses_nothing_on_the_other_output():
    from hapticfx_solenoid.bench.isolation import run_once, table

    alone, healthy, silent = (run_once(board, 12, 0.02) for board in ("none", "healthy", "silent"))
    assert alone["helmet"]["rendered"] == healthy["helmet"]["rendered"] == silent["helmet"]["rendered"] == 12
    assert alone["coil"] is None and alone["wav"].size == 12
    rows = table({"none": [alone], "healthy": [healthy], "silent": [silent]}).splitlines()[2:]
    assert [r.split(" | ")[0] for r in rows] == ["| none (the WAV output alone)", "| healthy",
                                                 "| silent after the handshake"]
    assert rows[0].endswith("| 12 | - |") and rows[1].endswith("| 12 | 3 / 0 / 0 |")
    assert healthy["coil"]["rendered"] == 3 and healthy["coil"]["failed"] == 0
    # the silent board's impacts fail (the first) or are cancelled at close (the rest): none is waited on
    assert silent["coil"]["rendered"] == 0 and silent["coil"]["failed"] >= 1
    assert silent["coil"]["failed"] + silent["coil"]["cancelled"] == 3 and silent["coil"]["pending"] == 0
