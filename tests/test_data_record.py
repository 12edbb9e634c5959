"""`data record` end to end: pyserial against the board emulator on a pseudo-terminal pair."""

import math
import os
import pty
import re
import threading
import tty

import numpy as np
import pytest

from hapticfx.board.emulator import AccelBoardEmulator
from hapticfx.board.protocol import GY61, parse_hello, parse_sample
from hapticfx.data.csv_import import read_csv_recordings
from hapticfx.board.record import impact_velocity, record_drops
from hapticfx.errors import DeviceError, SignalError

pytest.importorskip("serial")


def _impacts(amps, n=300):
    t = np.arange(n) / 1000.0
    env = np.exp(-t / 0.03)
    return [np.stack([a * env * np.sin(2 * np.pi * 110 * t + 0.3), 0.5 * a * env * np.sin(2 * np.pi * 170 * t),
                      0.3 * a * env * np.sin(2 * np.pi * 60 * t)], axis=1) for a in amps]


def test_hello_line_round_trips():
    info = parse_hello(GY61.hello_line())
    assert info == GY61
    assert parse_sample("65535,0,512,1023\n") == (65535, 0, 512, 1023)
    assert parse_sample("OK START") is None
    with pytest.raises(DeviceError, match="not a hapticfx accelerometer board"):
        parse_hello("Arduino ready")


def test_records_labelled_triggered_drops(tmp_path):
    impacts = _impacts([2.0, 2.5, 1.5])
    with AccelBoardEmulator(impacts) as emu:
        files = record_drops(emu.port, object_id="wood-beam", height_m=0.8, drops=3, out_dir=tmp_path,
                             pre_trigger=50, n_samples=600, timeout_s=20)
    assert emu.commands[:3] == ["STOP", "HELLO", "START"] and emu.commands[-1] == "STOP"
    assert [f.name for f in files] == [f"wood-beam_h0.8m_d{i:02d}.csv" for i in range(3)]
    recs, rate = read_csv_recordings(files)
    assert rate == 1000.0
    (rec,) = recs
    assert rec.velocities_mps.tolist() == [pytest.approx(math.sqrt(2 * 9.80665 * 0.8))]
    acc = rec.accel_g[0]  # (drops, samples, 3)
    assert acc.shape == (3, 600, 3)
    quantum = 1 / 102.4
    for d, imp in enumerate(impacts):
        # the pre-trigger samples are at rest (gravity on z) ...
        np.testing.assert_allclose(acc[d, :40], np.tile([0, 0, 1], (40, 1)), atol=4 * quantum + 0.02)
        # ... and the impact starts right after them; its samples come through quantised
        onset = int(np.argmax(np.linalg.norm(acc[d] - [0, 0, 1], axis=1) > 0.5))
        assert 48 <= onset <= 55
        start = onset - int(np.argmax(np.linalg.norm(imp, axis=1) > 0.5))
        np.testing.assert_allclose(acc[d, start:start + 300] - [0, 0, 1], imp, atol=quantum + 0.03)


def test_drop_numbers_continue_in_the_same_folder(tmp_path):
    with AccelBoardEmulator(_impacts([2.0, 2.0])) as emu:
        record_drops(emu.port, object_id="brick", height_m=0.5, drops=1, out_dir=tmp_path, n_samples=300)
        files = record_drops(emu.port, object_id="brick", height_m=0.5, drops=1, out_dir=tmp_path, n_samples=300)
    assert files[0].name == "brick_h0.5m_d01.csv"


def test_impacts_beyond_the_sensor_range_are_clipped(tmp_path):
    with AccelBoardEmulator(_impacts([8.0])) as emu:
        (f,) = record_drops(emu.port, object_id="steel-plate", height_m=1.0, drops=1, out_dir=tmp_path, n_samples=300)
    recs, _ = read_csv_recordings([f])
    acc = recs[0].accel_g
    assert np.all(np.isfinite(acc)) and np.max(np.abs(acc)) <= 3.6 + 0.01


def test_lost_samples_during_a_drop_are_an_error(tmp_path):
    with AccelBoardEmulator(_impacts([2.0]), lose_samples_at=360) as emu:
        with pytest.raises(DeviceError, match=r"3 sample\(s\) lost during drop 0"):
            record_drops(emu.port, object_id="x", height_m=0.5, drops=1, out_dir=tmp_path, n_samples=300)
    assert list(tmp_path.iterdir()) == []


def test_no_impact_times_out(tmp_path):
    with AccelBoardEmulator([], realtime=True) as emu:
        with pytest.raises(DeviceError, match=r"no impact above 0.5 g within 0.5 s \(0 of 1 drops recorded\)"):
            record_drops(emu.port, object_id="x", height_m=0.5, drops=1, out_dir=tmp_path, timeout_s=0.5)


def test_absent_or_silent_or_foreign_board(tmp_path):
    with pytest.raises(DeviceError, match="cannot open serial port"):
        record_drops("/dev/does-not-exist", object_id="x", height_m=0.5, drops=1, out_dir=tmp_path)
    master, slave = pty.openpty()
    tty.setraw(slave)
    try:
        with pytest.raises(DeviceError, match="no answer to HELLO"):
            record_drops(os.ttyname(slave), object_id="x", height_m=0.5, drops=1, out_dir=tmp_path, timeout_s=0.5)

        os.set_blocking(master, False)
        try:
            os.read(master, 4096)  # what the first attempt sent
        except BlockingIOError:
            pass
        os.set_blocking(master, True)

        def foreign():
            os.read(master, 100)
            os.write(master, b"Arduino ready v2\n")

        t = threading.Thread(target=foreign)
        t.start()
        with pytest.raises(DeviceError, match="not a hapticfx accelerometer board"):
            record_drops(os.ttyname(slave), object_id="x", height_m=0.5, drops=1, out_dir=tmp_path, timeout_s=2)
        t.join()
    finally:
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize("object_id, height_m, message", [
    ("../x", 0.8, "object id '../x' must be letters, digits"),  # wrote rec/../x_h0.8m_d00.csv, outside --out-dir
    ("x", 0.0, "height_m must be above 0"),  # 0 m/s drops, every line of which `data import` then refused
])
def test_an_object_id_that_is_a_path_or_a_height_of_0_is_refused_before_recording(tmp_path, object_id, height_m,
                                                                                   message):
    with pytest.raises(SignalError, match=message):
        record_drops("/dev/does-not-exist", object_id=object_id, height_m=height_m, drops=1, out_dir=tmp_path)
    assert not list(tmp_path.parent.glob("x_h*"))


def test_impact_velocity():
    assert impact_velocity(0.0) == 0.0
    assert impact_velocity(1.0) == pytest.approx(4.4287, abs=1e-4)


def test_board_left_streaming_by_a_previous_host(tmp_path):
    import serial

    with AccelBoardEmulator(_impacts([2.0, 2.0])) as emu:
        with serial.Serial(emu.port, 500000, timeout=1) as s:
            s.write(b"START\n")
            assert s.readline().strip() == b"OK START"
            assert parse_sample(s.readline().decode()) is not None
        files = record_drops(emu.port, object_id="x", height_m=0.5, drops=1, out_dir=tmp_path, n_samples=300)
    assert len(files) == 1


@pytest.mark.parametrize("field, value, expected", [
    ("rate_hz", "nan", "rate_hz=nan; expected 1 to 1e6 Hz"),
    ("rate_hz", "0", "rate_hz=0.0; expected 1 to 1e6 Hz"),
    ("counts_per_g", "inf,102.4,102.4", "counts_per_g=(inf, 102.4, 102.4); expected finite counts per g"),
    ("adc_bits", "-5", "adc_bits=-5; expected 1 to 32 bits"),
    ("zero", "512,512,99999", "zero=(512.0, 512.0, 99999.0); expected counts within the ADC's range"),
])
def test_hello_replies_with_impossible_numbers_are_refused(field, value, expected):
    line = " ".join(f"{k}={value}" if k == field else p for p in GY61.hello_line().split()
                    for k in [p.split("=", 1)[0]])
    with pytest.raises(DeviceError, match=re.escape(expected)):
        parse_hello(line)
