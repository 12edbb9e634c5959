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
    with pytest.raises(ValueError):  # nor by whoever is handed it, setting the flag back
        s.samples.setflags(write=True)
    assert s.duration_s == pytest.approx(0.004)


def test_an_adopted_array_is_not_copied_but_made_read_only():
    data = np.arange(4.0)
    s = Signal.adopt(data, 1000)
    assert s.samples is data and not data.flags.writeable
    assert s.rate_hz == 1000.0 and isinstance(s.rate_hz, float)


@pytest.mark.parametrize("bad, message", [(np.array([1.0, np.nan]), "non-finite"), (np.zeros((1, 1, 4)), "dimension"),
                                          (np.array([1 + 2j]), "real numbers")])
def test_an_adopted_array_passes_the_same_gate(bad, message):
    with pytest.raises(SignalError, match=message):
        Signal.adopt(bad, 1000)


@pytest.mark.parametrize("rate", [0, -1, float("nan")])
@pytest.mark.parametrize("make", [Signal, Signal.adopt])
def test_signal_rejects_bad_rate(rate, make):
    with pytest.raises(SignalError):
        make(np.zeros(4), rate)


@pytest.mark.parametrize("v", [float("nan"), float("inf"), -0.1, "3", None, True])
def test_velocity_gate(v):
    with pytest.raises(SignalError):
        valid_velocity(v)


def test_a_normal_too_long_to_measure_directly_is_still_made_unit():
    """(1.7e308,)*3 has a norm past the largest float: it came out (0, 0, 0) and failed as 'must not be zero'
    after the OSC bridge had accepted it."""
    from hapticfx.interfaces import valid_vector

    assert valid_vector([1.7e308] * 3, name="normal", unit=True) == pytest.approx((3 ** -0.5,) * 3)
    assert valid_vector([3e-9, 0.0, 0.0], name="normal", unit=True) == (1.0, 0.0, 0.0)
    with pytest.raises(SignalError, match="must not be zero"):
        valid_vector([1e-10, 0.0, 0.0], name="normal", unit=True)
