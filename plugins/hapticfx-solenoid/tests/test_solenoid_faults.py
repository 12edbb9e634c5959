"""Faults on the serial line: the board goes silent, answers garbage, babbles without
line ends, or the port closes (unplugged). Each is a DeviceError within 1 s, closing
afterwards neither raises nor hangs, and an embedding program carries on."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from hapticfx.errors import DeviceError
from hapticfx.params import BuildContext
from hapticfx.signal import Signal
from hapticfx_solenoid.actuator import SolenoidActuator
from hapticfx_solenoid.emulator import FAULTS, Fault, Firmware, PtyEmulator

MESSAGES = {
    "silent": "no answer to PING within 0.5 s",
    "garbage": "not the hapticfx solenoid protocol",
    "babble": "no complete reply line to PING",
    "close": "serial port failed during PING",
}
PULSE = Signal(np.r_[np.zeros(5), np.full(20, 0.8), np.zeros(75)], 1000.0)


def solenoid(port: str) -> SolenoidActuator:
    return SolenoidActuator(SolenoidActuator.Params(port=port, timeout_s=0.5), BuildContext())


@pytest.mark.parametrize("kind", FAULTS)
def test_fault_during_handshake(kind):
    with PtyEmulator(Firmware(), fault=Fault(kind)) as emu:
        act = solenoid(emu.port)
        start = time.monotonic()
        with pytest.raises(DeviceError, match=MESSAGES[kind]) as info:
            act.open()
        assert time.monotonic() - start < 1.0
        assert emu.port in str(info.value) and "\n" not in str(info.value)
        start = time.monotonic()
        act.close()  # nothing to close, must not raise
        assert time.monotonic() - start < 0.1


@pytest.mark.parametrize("kind", FAULTS)
def test_fault_in_the_middle_of_a_session(kind):
    with PtyEmulator(Firmware(), fault=Fault(kind, after=2)) as emu:  # PING and STATUS answered
        act = solenoid(emu.port)
        act.open()
        start = time.monotonic()
        with pytest.raises(DeviceError, match="FIRE") as info:
            act.play(PULSE)
        assert time.monotonic() - start < 1.0
        assert emu.port in str(info.value)
        seen = emu.lines_seen
        start = time.monotonic()
        act.close()  # the board stopped answering: STOP is sent, its reply not awaited
        assert time.monotonic() - start < 1.0
        if kind != "close":  # a closed port takes nothing more
            deadline = time.monotonic() + 2.0
            while emu.lines_seen == seen and time.monotonic() < deadline:
                time.sleep(0.01)
            assert emu.lines_seen == seen + 1  # STOP reached the board all the same


def test_port_that_does_not_exist():
    start = time.monotonic()
    with pytest.raises(DeviceError, match="cannot open serial port"):
        solenoid("/dev/ttyACM-hapticfx-missing").open()
    assert time.monotonic() - start < 1.0


def test_port_that_is_not_a_tty(tmp_path):
    plain = tmp_path / "not-a-port"
    plain.write_text("")
    with pytest.raises(DeviceError, match="cannot open serial port"):
        solenoid(str(plain)).open()


def test_embedding_program_survives_every_fault():
    program = textwrap.dedent("""
        import time, threading
        import numpy as np
        from hapticfx.errors import HapticfxError
        from hapticfx.params import BuildContext
        from hapticfx.signal import Signal
        from hapticfx_solenoid.actuator import SolenoidActuator
        from hapticfx_solenoid.emulator import FAULTS, Fault, Firmware, PtyEmulator

        pulse = Signal(np.r_[np.zeros(5), np.full(20, 0.8), np.zeros(75)], 1000.0)
        for kind in FAULTS:
            for after in (0, 2):
                with PtyEmulator(Firmware(), fault=Fault(kind, after)) as emu:
                    act = SolenoidActuator(SolenoidActuator.Params(port=emu.port), BuildContext())
                    start = time.monotonic()
                    try:
                        with act:
                            act.play(pulse)
                        print(kind, after, "played?!")
                    except HapticfxError as exc:
                        print(kind, after, "error", round(time.monotonic() - start, 3), type(exc).__name__)
        # the program goes on: a healthy board still works afterwards
        with PtyEmulator() as emu, SolenoidActuator(SolenoidActuator.Params(port=emu.port), BuildContext()) as act:
            act.play(pulse)
            print("healthy", act.report.fired)
        print("threads", threading.active_count())
    """)
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    errors = [line.split() for line in lines if " error " in line]
    assert len(errors) == 2 * len(FAULTS)
    assert all(name == "DeviceError" for *_, name in errors)
    assert all(float(seconds) < 2.0 for _, _, _, seconds, _ in errors)  # error within 1 s, plus close's STOP
    assert "healthy 1" in lines and "threads 1" in lines
    assert done.stderr == ""
