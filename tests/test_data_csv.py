"""CSV import: a good file round-trips; bad files are rejected with file + line, nothing left behind."""

import numpy as np
import pytest

from hapticfx.data.csv_import import COLUMNS, import_csv
from hapticfx.data.dataset import open_dataset
from hapticfx.errors import DatasetError

HEADER = ",".join(COLUMNS)


def _rows(obj="wood-beam", velocities=(2.42, 3.96), drops=2, n=200, rate=1000.0, seed=0):
    rng = np.random.default_rng(seed)
    rows = []
    for v in velocities:
        for d in range(drops):
            t = np.arange(n) / rate
            a = np.zeros((n, 3))
            a[:, 2] = 1.0
            a[n // 3:, 0] += v * np.exp(-t[: n - n // 3] / 0.03) * np.sin(2 * np.pi * 120 * t[: n - n // 3])
            a += rng.normal(0, 0.01, a.shape)
            rows += [f"{obj},{v},{d},{ti:.6f},{x:.6g},{y:.6g},{z:.6g}" for ti, (x, y, z) in zip(t, a)]
    return rows


def _write(tmp_path, lines, name="in.csv"):
    f = tmp_path / name
    f.write_text("\n".join(lines) + "\n")
    return f


def _leftovers(tmp_path):
    return sorted(p.name for p in tmp_path.iterdir() if p.suffix != ".csv")


def test_good_file_round_trips(tmp_path):
    rows = _rows()
    f = _write(tmp_path, [HEADER] + rows[::-1][::-1])
    out = import_csv([f], tmp_path / "ds", sensor={"model": "ADXL335"})
    ds = open_dataset(out)
    v, acc = ds.raw("wood-beam")
    assert v.tolist() == [2.42, 3.96] and acc.shape == (2, 2, 200, 3)
    first = rows[0].split(",")
    np.testing.assert_allclose(acc[0, 0, 0], [float(x) for x in first[4:]], rtol=1e-6)
    assert ds.raw_rate_hz == 1000.0 and ds.meta["sensor"] == {"model": "ADXL335"}
    assert ds.meta["provenance"]["files"][0]["name"] == "in.csv"
    assert ds.bank("wood-beam", "max-min").profiles.shape == (2, 500)
    assert ds.bank("wood-beam", "dft321").profiles.shape == (2, 500)


def test_rows_of_drops_may_be_interleaved_and_split_over_files(tmp_path):
    rows = _rows()
    a = _write(tmp_path, [HEADER] + rows[:300], "a.csv")
    b = _write(tmp_path, [HEADER] + rows[300:], "b.csv")
    ds = open_dataset(import_csv([a, b], tmp_path / "ds"))
    assert ds.raw("wood-beam")[1].shape == (2, 2, 200, 3)


def _bad(tmp_path, lines, match):
    f = _write(tmp_path, lines)
    with pytest.raises(DatasetError, match=match) as err:
        import_csv([f], tmp_path / "ds")
    assert not (tmp_path / "ds").exists()
    assert _leftovers(tmp_path) == []
    assert str(f) in str(err.value)
    return str(err.value)


def _replace(rows, i, field, value):
    parts = rows[i].split(",")
    parts[field] = value
    rows[i] = ",".join(parts)
    return rows


def test_empty_file(tmp_path):
    _bad(tmp_path, [], "empty file; expected the header object,velocity_mps")


def test_wrong_header(tmp_path):
    _bad(tmp_path, ["object,velocity,drop,t_s,ax_g,ay_g,az_g"] + _rows(), r"line 1: header must be.*missing velocity_mps.*unexpected velocity")


def test_missing_axis(tmp_path):
    rows = _rows()
    rows[10] = ",".join(rows[10].split(",")[:6])
    _bad(tmp_path, [HEADER] + rows, r"line 12: expected 7 fields .* got 6 \(missing axis\?\)")


def test_empty_axis_value(tmp_path):
    _bad(tmp_path, [HEADER] + _replace(_rows(), 4, 6, ""), r"line 6: az_g is empty")


def test_nan_value(tmp_path):
    _bad(tmp_path, [HEADER] + _replace(_rows(), 7, 4, "nan"), r"line 9: ax_g is nan \(expected a finite number\)")


def test_not_a_number(tmp_path):
    _bad(tmp_path, [HEADER] + _replace(_rows(), 2, 5, "0.1g"), r"line 4: ay_g '0.1g' is not a number")


def test_time_not_increasing(tmp_path):
    rows = _rows()
    rows[21], rows[22] = rows[22], rows[21]
    _bad(tmp_path, [HEADER] + rows, r"line 24: t_s 0.021 is not after the previous sample's 0.022")


def test_mixed_rates_between_drops(tmp_path):
    rows = _rows(velocities=(2.42,), drops=1) + _rows(velocities=(3.96,), drops=1, rate=2000.0)
    _bad(tmp_path, [HEADER] + rows, r"line 202: .*3.96 m/s, drop 0 is at 2000 Hz but .*2.42 m/s, drop 0 is at 1000 Hz \(mixed rates")


def test_irregular_sample_interval(tmp_path):
    rows = _rows(velocities=(2.42,), drops=1)
    _bad(tmp_path, [HEADER] + rows[:50] + rows[51:], r"line 52: .*sample interval 0.002 s differs")


def test_too_few_samples(tmp_path):
    _bad(tmp_path, [HEADER] + _rows(velocities=(2.42,), drops=1, n=20), r"line 2: .*has 20 samples; at least 64")


def test_bad_velocity_and_drop(tmp_path):
    msg = _bad(tmp_path, [HEADER] + _replace(_replace(_rows(), 0, 1, "-1"), 1, 2, "x"),
               r"2 problem\(s\)")
    assert "line 2: velocity_mps -1.0 must be > 0" in msg and "line 3: drop 'x' must be a non-negative integer" in msg


def test_unknown_object_needs_a_mass(tmp_path):
    _bad(tmp_path, [HEADER] + _rows(obj="teapot"), r"line 2: object 'teapot' is not built in.*--mass teapot=KG")
    out = import_csv([tmp_path / "in.csv"], tmp_path / "ds", masses={"teapot": 0.4})
    assert open_dataset(out).object_info("teapot").mass_kg == 0.4


def test_unequal_drop_counts(tmp_path):
    rows = _rows(velocities=(2.42,), drops=2) + _rows(velocities=(3.96,), drops=1)
    _bad(tmp_path, [HEADER] + rows, r"every velocity needs the same number of drops")


def test_many_errors_are_all_counted(tmp_path):
    rows = _rows()
    for i in range(0, 40, 2):
        _replace(rows, i, 4, "nan")
    msg = _bad(tmp_path, [HEADER] + rows, r"in.csv: 20 problem\(s\): line 2: ax_g is nan")
    assert msg.endswith("and 17 more")


def test_missing_file_and_existing_output(tmp_path):
    with pytest.raises(DatasetError, match="file not found"):
        import_csv([tmp_path / "nope.csv"], tmp_path / "ds")
    f = _write(tmp_path, [HEADER] + _rows())
    import_csv([f], tmp_path / "ds")
    with pytest.raises(DatasetError, match="already exists"):
        import_csv([f], tmp_path / "ds")
    import_csv([f], tmp_path / "ds", overwrite=True)


def test_a_spreadsheets_byte_order_mark_is_not_part_of_the_header(tmp_path):
    """A file saved as "CSV UTF-8" by a spreadsheet starts with a BOM: `missing object; unexpected \ufeffobject`."""
    f = tmp_path / "in.csv"
    f.write_bytes(("\n".join([HEADER] + _rows()) + "\n").encode("utf-8-sig"))
    assert open_dataset(import_csv([f], tmp_path / "ds")).raw("wood-beam")[1].shape == (2, 2, 200, 3)


def test_a_rate_the_high_pass_leaves_nothing_of_is_refused_naming_the_file_and_line(tmp_path):
    """10 Hz passed the rate check and then failed in preprocessing, naming no file: the high-pass cutoff 20.0 Hz
    is not below the Nyquist frequency of 10.0 Hz."""
    _bad(tmp_path, [HEADER] + _rows(rate=10.0, n=100), r"line 2: .*a rate of 10 Hz; expected above 40 Hz")


def test_a_velocity_above_the_limit_says_the_limit(tmp_path):
    _bad(tmp_path, [HEADER] + _replace(_rows(), 0, 1, "1000"), r"line 2: velocity_mps 1000 is above 100$")


def test_absurd_numbers_and_object_ids_are_refused(tmp_path):
    rows = _rows(velocities=(2.42,), drops=1)
    _bad(tmp_path, [HEADER] + _replace(list(rows), 5, 4, "1e308"), r"line 7: ax_g 1e\+308 is outside \[-10000, 10000\]")
    fast = [r.replace(f",{t},", f",{float(t) * 1e-9:.17g},") for r in rows for t in [r.split(",")[3]]]
    _bad(tmp_path, [HEADER] + fast, r"sample interval 1e-12 s is a rate of 1e\+12 Hz; expected above 40 Hz \(twice "
                                    r"the high-pass\) to 1e\+06 Hz")
    _bad(tmp_path, [HEADER] + [r.replace("wood-beam", "../../etc/x") for r in rows],
         r"object '../../etc/x' must be 1-64 letters, digits")
