"""The solenoid actuator talking to the emulator through pyserial over a real pty pair."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from hapticfx.errors import DeviceError
from hapticfx.params import BuildContext
from hapticfx.registry import get_registry
from hapticfx.signal import Signal
from hapticfx_solenoid.actuator import Pulse, SolenoidActuator
from hapticfx_solenoid.emulator import Firmware, PtyEmulator
from hapticfx_solenoid.link import SerialLink
from hapticfx_solenoid.protocol import FirmwareLimits


def square(amplitude: float, on_ms: int, total_ms: int = 500, start_ms: int = 10) -> Signal:
    """Paper Eq. 11 at 1 kHz: ``amplitude`` for ``on_ms``, zero elsewhere."""
    x = np.zeros(total_ms)
    x[start_ms:start_ms + on_ms] = amplitude
    return Signal(x, 1000.0)


def actuator_on(port: str, **params) -> SolenoidActuator:
    return SolenoidActuator(SolenoidActuator.Params(port=port, **params), BuildContext())


def wait_pulse_end(act: SolenoidActuator) -> None:
    """Until the last pulse has ended and its run with it: the next pulse starts a run of its own."""
    time.sleep(act.last_pulse.on_ms / 1000 + 0.02)


def test_open_handshakes_and_reads_the_boards_limits(emulator):
    act = actuator_on(emulator.port)
    with act:
        assert act.firmware_id == "hapticfx-solenoid-emulator/1.0"
        assert act.firmware_status["max_on_ms"] == 100 and act.firmware_status["budget_ms"] == 2500
        assert emulator.port in act.describe()
    assert emulator.lines_seen == 3  # PING, STATUS, and STOP on close


def test_square_pulse_becomes_one_pulse_of_the_same_width(emulator):
    with actuator_on(emulator.port) as act:
        act.play(square(0.5, 40))
    assert act.last_pulse == Pulse(40, round(255 * (0.3 + 0.7 * 0.5)))
    (start, on_ms, duty), = emulator.firmware.pulses
    assert (on_ms, duty) == (40, 166)
    assert act.report.fired == 1


@pytest.mark.parametrize("amplitude", [0.2, 0.6, 1.0])
def test_width_encoding_scales_width_at_full_power(emulator, amplitude):
    with actuator_on(emulator.port, encoding="width") as act:
        act.play(square(amplitude, 10))
    assert emulator.firmware.pulses[-1][1:] == (round(100 * amplitude), 255)


def test_fixed_width_and_stronger_impacts_give_higher_duty(emulator):
    with actuator_on(emulator.port, width_ms=25.0) as act:
        for amplitude in (0.1, 0.4, 0.9):
            act.play(square(amplitude, 5))
            wait_pulse_end(act)
    widths = [p[1] for p in emulator.firmware.pulses]
    duties = [p[2] for p in emulator.firmware.pulses]
    assert widths == [25, 25, 25]
    assert duties == sorted(duties) and len(set(duties)) == 3


def test_waveform_width_is_time_above_threshold(emulator):
    t = np.arange(500) / 1000.0
    wave = 0.8 * np.exp(-t / 0.02) * np.sin(2 * np.pi * 100 * t)  # a decaying impact ring
    sig = Signal(wave, 1000.0)
    act = actuator_on(emulator.port)
    pulse = act.pulse_for(sig)
    expected_ms = int(np.count_nonzero(np.abs(wave) >= 0.5 * np.abs(wave).max()))
    assert pulse.on_ms == expected_ms and 1 <= pulse.on_ms < 50
    with act:
        act.play(sig)
    assert emulator.firmware.pulses[-1][1] == expected_ms


def test_silence_fires_nothing(emulator):
    with actuator_on(emulator.port) as act:
        act.play(Signal(np.zeros(100), 1000.0))
        act.play(square(0.005, 30))
    assert act.report.silent == 2 and act.report.fired == 0
    assert emulator.firmware.pulses == []


def test_host_shortens_a_pulse_longer_than_max_on_time(emulator):
    with actuator_on(emulator.port) as act:
        act.play(square(1.0, 300))
    assert act.report.shortened_on_time == 1
    assert emulator.firmware.pulses[-1][1:] == (100, 255)
    assert emulator.firmware.refused == 0  # the host never asked the board for more than it allows


def test_host_duty_cycle_shortens_then_refuses_and_counts(emulator):
    act = actuator_on(emulator.port)
    act.limits = act.spec.limits.lowered(max_duty=0.01)  # what an effect's `limits:` does: 100 ms per 10 s
    with act:
        act.play(square(1.0, 70))
        wait_pulse_end(act)
        act.play(square(1.0, 50))  # only 30 ms left
        wait_pulse_end(act)
        act.play(square(1.0, 50))  # nothing left
    assert [p[1] for p in emulator.firmware.pulses] == [70, 30]
    assert (act.report.fired, act.report.shortened_duty, act.report.refused_duty) == (2, 1, 1)
    assert emulator.firmware.refused == 0


def test_host_refuses_while_a_pulse_is_on(emulator):
    with actuator_on(emulator.port) as act:
        act.play(square(1.0, 80))
        act.play(square(1.0, 80))
    assert act.report.refused_busy == 1 and len(emulator.firmware.pulses) == 1


def longest_run_ms(pulses: list[tuple[int, int, int]], gap_ms: int = 10) -> int:
    """The longest time the coil was on, from the board's log, pulses less than ``gap_ms`` apart taken as one run
    (as the limiter counts a pulse), their gaps counted as on."""
    longest, start, end = 0, None, None
    for at, on_ms, _ in sorted(pulses):
        if start is None or at - end >= gap_ms:
            start = at
        end = max(end or 0, at + on_ms)
        longest = max(longest, end - start)
    return longest


def test_pulses_back_to_back_keep_to_the_on_time_limit_together(emulator):
    """5 ms pulses, each fired as soon as the last had ended, kept the coil on for 2.5 s with 1 ms gaps
    (max_on_s 0.1 s): a pulse less than 10 ms after the last one continues it."""
    with actuator_on(emulator.port) as act:
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            act.play(square(1.0, 5))
            time.sleep(0.0005)
        pulses = list(emulator.firmware.pulses)
    assert len(pulses) > 10  # (how many the host refused for the run's sake depends on this machine's pace)
    assert longest_run_ms(pulses) <= 100
    assert longest_run_ms([(0, 80, 255), (81, 19, 255), (150, 5, 255)]) == 100  # the measure itself


def test_a_pulse_right_after_another_gets_what_the_run_has_left(emulator):
    with actuator_on(emulator.port) as act:
        act.play(square(1.0, 80))
        wait_pulse_end(act)
        act.play(square(1.0, 80))
        time.sleep(act.last_pulse.on_ms / 1000 + 0.002)  # 2 ms after: the same run
        act.play(square(1.0, 80))
    pulses = emulator.firmware.pulses
    assert [p[1] for p in pulses[:2]] == [80, 80]
    if len(pulses) == 3:
        (start, second, _), (then, third, _) = pulses[1], pulses[2]
        if then - (start + second) < 10:  # as meant; a machine too busy to fire within the gap starts a new run
            assert third <= 100 - (then - start) and act.report.shortened_on_time == 1
    else:  # fired so late in the run that less than min_pulse_ms was left of it: refused, by the host or the board
        assert act.report.refused_on_time + act.report.refused_by_board == 1
    assert longest_run_ms(pulses) <= 100


def test_host_adopts_a_stricter_board():
    strict = Firmware(FirmwareLimits(max_on_ms=20, duty_permille=250, window_ms=10_000))
    with PtyEmulator(strict) as emu, actuator_on(emu.port) as act:
        act.play(square(1.0, 60))
    assert emu.firmware.pulses[-1][1] == 20 and act.report.shortened_on_time == 1


def test_board_enforces_its_limits_on_its_own(emulator):
    link = SerialLink(emulator.port)
    link.open()
    try:
        assert link.request("FIRE 500 255") == "ERR LIMIT max on-time 100 ms"
        for _ in range(25):  # 25 x 100 ms = the whole 2.5 s budget, with no host book-keeping
            assert link.request("FIRE 100 255") == "OK FIRE 100 255"
            time.sleep(0.115)  # each a run of its own
        assert link.request("FIRE 100 255").startswith(("ERR DUTY", "ERR BUSY"))
    finally:
        link.close()


def test_board_refusal_is_counted_not_raised():
    board = Firmware(FirmwareLimits(max_on_ms=100, duty_permille=10, window_ms=10_000))  # 100 ms budget
    with PtyEmulator(board) as emu, actuator_on(emu.port) as act:
        board.handle("FIRE 90 255")  # someone else used the board's budget: the host's book cannot know
        time.sleep(0.1)
        act.play(square(1.0, 50))
    assert act.report.refused_by_board == 1 and act.report.fired == 0


def test_context_device_overrides_port(emulator):
    act = SolenoidActuator(SolenoidActuator.Params(port="/dev/ttyDOES-NOT-EXIST"), BuildContext(device=emulator.port))
    with act:
        act.play(square(0.7, 20))
    assert len(emulator.firmware.pulses) == 1


def test_play_before_open_and_no_port_are_device_errors():
    act = SolenoidActuator(SolenoidActuator.Params(), BuildContext())
    with pytest.raises(DeviceError, match="play\\(\\) before open\\(\\)"):
        act.play(square(1.0, 10))
    with pytest.raises(DeviceError, match="no serial port"):
        act.open()


def test_builtin_emulator_port(tmp_path):
    with actuator_on("emulator") as act:
        act.play(square(0.5, 30))
        assert "/dev/pts/" in act._link.port
    assert act.report.fired == 1 and act._emulator is None


def test_registered_lazily_without_importing_serial():
    reg = get_registry().get("actuator", "solenoid")
    assert reg.distribution == "hapticfx-solenoid"
    code = ("import sys; from hapticfx.registry import get_registry; r = get_registry(); "
            "assert 'solenoid' in r.names('actuator'); print('serial' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_pipeline_plays_the_kinetic_energy_pulse(tmp_path, emulator):
    from hapticfx.pipeline import Pipeline

    effect = tmp_path / "brick.yaml"
    effect.write_text(textwrap.dedent("""\
        name: brick-solenoid
        object: concrete-brick
        velocity_mps: 3.8
        model: {type: kinetic-energy, pulse_ms: 30}
        actuator: {type: solenoid, device: /dev/ttyNOT-USED, gain: 1.0}
    """))
    with Pipeline.from_effect(effect, device=emulator.port) as pipeline:
        delivery = pipeline.impact(velocity=3.8)
    (start, on_ms, duty), = emulator.firmware.pulses
    assert on_ms == 30
    assert duty == round(255 * (0.3 + 0.7 * min(delivery.output.peak, 1.0)))


def test_emulator_command_line(tmp_path):
    link = tmp_path / "solenoid"
    proc = subprocess.Popen([sys.executable, "-m", "hapticfx_solenoid.emulator", "--link", str(link)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == str(link)
        assert os.path.realpath(link).startswith("/dev/pts/")
        with actuator_on(str(link)) as act:
            act.play(square(0.9, 15))
            status = act._link.request("STATUS")
        assert "fired=1" in status
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=5) == 0
    assert not link.exists()


def test_bench_round_trips():
    from hapticfx_solenoid.bench.roundtrip import round_trips

    times = round_trips(20)
    assert len(times) == 20 and all(0 < t < 1.0 for t in times)


@pytest.mark.parametrize("amplitude", [0.0, 0.01, 0.0100001, 0.5, 1.0, 3.0, 1e300])
@pytest.mark.parametrize("encoding", ["pwm", "width"])
def test_pulse_is_bounded_at_the_edges(amplitude, encoding):
    act = actuator_on("unused", encoding=encoding)
    pulse = act.pulse_for(Signal(np.r_[np.zeros(3), np.full(40, amplitude), np.zeros(3)], 1000.0))
    if amplitude <= 0.01:
        assert pulse is None
        return
    assert 0 <= pulse.duty <= 255 and 1 <= pulse.on_ms
    if amplitude >= 1.0:
        assert pulse.duty == 255
    if encoding == "width":
        assert pulse.on_ms <= 100


def test_two_channel_signal_uses_the_stronger_channel():
    act = actuator_on("unused")
    both = Signal(np.vstack([np.r_[np.full(10, 0.2), np.zeros(40)], np.r_[np.zeros(10), np.full(30, 0.6), np.zeros(10)]]), 1000.0)
    assert act.pulse_for(both) == Pulse(30, round(255 * (0.3 + 0.7 * 0.6)))


def test_out_of_range_params_are_rejected_when_built_directly():
    from hapticfx.errors import HapticfxError

    with pytest.raises(HapticfxError, match="timeout_s must be <= 1.0"):
        SolenoidActuator(SolenoidActuator.Params(timeout_s=5.0), BuildContext())


def test_effect_limits_reach_the_board(tmp_path, emulator):
    from hapticfx.pipeline import Pipeline

    effect = tmp_path / "short.yaml"
    effect.write_text("name: short\nobject: steel-plate\nvelocity_mps: 5.0\nmodel: {type: kinetic-energy, pulse_ms: 30}\n"
                      "actuator: {type: solenoid, gain: 1.0, limits: {max_on_s: 0.02}}\n")
    with Pipeline.from_effect(effect, device=emulator.port) as pipeline:
        pipeline.impact()
        assert pipeline.actuator.limits.max_on_s == 0.02
    (_, on_ms, _), = emulator.firmware.pulses
    assert on_ms <= 20


def test_plays_from_several_threads_keep_the_line_in_order(emulator):
    import threading

    errors = []

    def worker(act):
        for _ in range(30):
            try:
                act.play(square(0.5, 2))
            except Exception as exc:  # any error here means replies got mixed up
                errors.append(exc)
            time.sleep(0.001)

    with actuator_on(emulator.port) as act:
        threads = [threading.Thread(target=worker, args=(act,)) for _ in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert errors == []
    r = act.report
    assert r.fired + r.refused_busy + r.refused_by_board == 90
    assert r.fired == len(emulator.firmware.pulses) >= 10
    assert emulator.firmware.refused == r.refused_by_board
