import numpy as np
import pytest

from hapticfx import Signal, valid_signal
from hapticfx.errors import SignalError
from hapticfx.signal import valid_velocity


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_valid_signal_returns_float64(dtype):
    out = valid_signal(np.ones(8, dtype=dtype))
    assert out.dtype == np.float64 and out.shape == (8,)


@pytest.mark.parametrize("bad, message", [
    (np.array([1.0, np.nan]), "1 non-finite value"),
    (np.array([np.inf, 1.0, -np.inf]), "2 non-finite value"),
    (np.array([1 + 2j]), "must be real numbers"),
    (np.array(["a"]), "must be real numbers"),
    (np.zeros(0), "is empty"),
    (np.float64(1.0), "is empty"),
])
def test_valid_signal_rejects(bad, message):
    with pytest.raises(SignalError, match=message):
        valid_signal(bad)


def test_signal_is_frozen_and_copied():
    data = np.arange(4.0)
    s = Signal(data, 1000)
    data[0] = 99
    assert s.samples[0] == 0
    with pytest.raises(ValueError):
        s.samples[0] = 1
    assert s.duration_s == pytest.approx(0.004)


@pytest.mark.parametrize("rate", [0, -1, float("nan")])
def test_signal_rejects_bad_rate(rate):
    with pytest.raises(SignalError):
        Signal(np.zeros(4), rate)


@pytest.mark.parametrize("v", [float("nan"), float("inf"), -0.1, "3", None, True])
def test_velocity_gate(v):
    with pytest.raises(SignalError):
        valid_velocity(v)
