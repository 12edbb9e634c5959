"""Tests of the envelope-csv format: write then read, and a broken file refused."""

import numpy as np
import pytest

from hapticfx.formats import ExportOptions, HapticFileError, format_for
from hapticfx.formats.device import PRESETS
from hapticfx.registry import get_registry
from hapticfx.signal import Signal
from hapticfx_csvlog.envelope import EnvelopeCsv


def test_write_then_read(tmp_path):
    t = np.arange(9600) / 48000
    x = Signal(0.5 * np.exp(-t / 0.1) * np.sin(2 * np.pi * 127.5 * t), 48000.0)
    path = tmp_path / "knock.env.csv"
    EnvelopeCsv().write(path, x, ExportOptions(device=PRESETS["quest"]))
    y = EnvelopeCsv().read(path, PRESETS["quest"], rate_hz=48000.0).signal  # 127.5 Hz: Quest's middle frequency
    assert np.max(np.abs(y.samples)) == pytest.approx(np.max(np.abs(x.samples)), rel=0.15)


def test_a_broken_file_names_itself(tmp_path):
    path = tmp_path / "bad.env.csv"
    path.write_text("0.0,0.1\n0.1,1.5\n")
    with pytest.raises(HapticFileError, match=r"bad.env.csv: line 2: amplitude 0-1"):
        EnvelopeCsv().read(path, PRESETS["quest"], rate_hz=8000.0)


def test_registered_and_found_by_its_suffix(tmp_path):
    assert get_registry().get("format", "envelope-csv").distribution == "hapticfx-example-actuator"
    assert format_for(tmp_path / "x.env.csv").name == "envelope-csv"
