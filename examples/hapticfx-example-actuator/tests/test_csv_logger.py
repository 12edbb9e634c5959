"""Tests of the csv-logger actuator: the kind of tests a plugin should ship."""

import numpy as np
import pytest

from hapticfx.errors import DeviceError
from hapticfx.params import BuildContext
from hapticfx.registry import get_registry
from hapticfx.signal import Signal
from hapticfx_csvlog.actuator import CsvLogger, read_log


def test_rows_round_trip_exactly(tmp_path):
    out = tmp_path / "log.csv"
    first = Signal(np.sin(np.linspace(0, 7, 300)) * 0.4, 1000.0)
    second = Signal(np.vstack([np.full(50, 0.25), np.full(50, -0.5)]), 1000.0)
    with CsvLogger(CsvLogger.Params(path=str(out)), BuildContext()) as logger:
        logger.play(first)
        assert not out.exists()  # nothing appears before close: no half-written file
        logger.play(second)
    rows = read_log(out)
    assert [(r["impact"], r["channel"]) for r in rows] == [(0, 0), (1, 0), (1, 1)]
    np.testing.assert_array_equal(rows[0]["samples"], first.samples)
    assert rows[2]["peak"] == 0.5 and rows[2]["above_half_s"] == 0.05
    assert rows[0]["rms"] == pytest.approx(np.sqrt(np.mean(first.samples ** 2)), rel=1e-15)


def test_device_overrides_path_and_relative_paths_follow_the_effect(tmp_path):
    assert CsvLogger(CsvLogger.Params(path="a.csv"), BuildContext(base_dir=tmp_path)).path == tmp_path / "a.csv"
    assert CsvLogger(CsvLogger.Params(path="a.csv"), BuildContext(device=str(tmp_path / "b.csv"))).path == tmp_path / "b.csv"


def test_missing_directory_is_a_device_error_on_open_not_on_construction(tmp_path):
    logger = CsvLogger(CsvLogger.Params(path=str(tmp_path / "no" / "log.csv")), BuildContext())
    with pytest.raises(DeviceError, match="cannot write a CSV log"):
        logger.open()


def test_registered_under_its_type_name():
    assert get_registry().get("actuator", "csv-logger").distribution == "hapticfx-example-actuator"


def test_the_host_keeps_the_limit_on_the_sum_unless_a_mixer_passes_its_conformance_check():
    """The logger does not sum overlapping impacts (``limits_mix`` is False), so the host limits what it gets.
    An actuator that sums them and declares ``limits_mix = True`` ships this check of its own limiter,
    ``assert_mix_limiter(ItsClass)``, and the host runs it too before it leaves the sum to it
    (docs/plugin-guide.md); without a ``mix_probe`` the check fails and the host keeps the limit."""
    from hapticfx.testing import assert_mix_limiter

    assert not CsvLogger.limits_mix
    with pytest.raises(AssertionError, match="has no mix_probe"):
        assert_mix_limiter(CsvLogger)
