"""`Signal`, the value that flows between stages, and the validation gate."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import SignalError


def valid_signal(samples, *, name: str = "signal", ndim: int | tuple[int, ...] | None = None) -> np.ndarray:
    """Return ``samples`` as a float64 array, or raise :class:`SignalError`.

    The one gate every public entry point goes through: a real floating or
    integer dtype (no complex, no object), finite values, and (when given)
    the number of dimensions. Time is the last axis.
    """
    arr = np.asarray(samples)
    if arr.dtype.kind not in "fiu":
        raise SignalError(f"{name} must be real numbers, got dtype {arr.dtype}")
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else ndim
        if arr.ndim not in allowed:
            raise SignalError(f"{name} must have {' or '.join(map(str, allowed))} dimension(s), got shape {arr.shape}")
    if arr.ndim == 0 or arr.shape[-1] == 0:
        raise SignalError(f"{name} is empty (shape {arr.shape})")
    arr = arr.astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise SignalError(f"{name} has {bad} non-finite value(s) (NaN or infinity)")
    return arr


def valid_number(value, *, name: str, minimum: float | None = None, maximum: float | None = None) -> float:
    """Return ``value`` as a finite float within [minimum, maximum], or raise :class:`SignalError`."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise SignalError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    try:
        v = float(value)
    except OverflowError:  # an integer beyond any float
        raise SignalError(f"{name} must be a number of ordinary size, got one of {len(str(value))} digits") from None
    if not math.isfinite(v):
        raise SignalError(f"{name} must be finite, got {v}")
    if minimum is not None and v < minimum:
        raise SignalError(f"{name} must be >= {minimum}, got {v}")
    if maximum is not None and v > maximum:
        raise SignalError(f"{name} must be <= {maximum}, got {v}")
    return v


def valid_rate(value, *, name: str) -> float:
    """A sample rate in Hz: a finite number above 0, as a float."""
    rate = valid_number(value, name=name)
    if rate <= 0:
        raise SignalError(f"{name} must be > 0, got {rate}")
    return rate


MAX_VELOCITY_MPS = 100.0  # a falling object, a ball, a wheel: no impact here comes near it
MAX_AT_S = 1e12  # an impact's time (s): well past any wall clock's, short of overflowing a file's frame count
# One impact's profile, as a model renders it: at most as long as the longest haptic file hapticfx renders, and
# as many samples as that at 192 kHz, the highest rate a built-in model renders at (a haptic file's).
MAX_PROFILE_S = 120.0
MAX_PROFILE_SAMPLES = int(MAX_PROFILE_S * 192_000)


def valid_velocity(value) -> float:
    """An impact velocity in m/s: finite, not negative, at most :data:`MAX_VELOCITY_MPS`."""
    return valid_number(value, name="velocity", minimum=0.0, maximum=MAX_VELOCITY_MPS)


def _sealed(arr: np.ndarray) -> np.ndarray:
    """A copy of ``arr`` that nothing can write: its memory is a ``bytes`` object, so numpy refuses
    ``setflags(write=True)`` on it and on every view of it (as it does not for an array that owns its memory,
    or one whose base is writable)."""
    return np.frombuffer(arr.tobytes(), dtype=np.float64).reshape(arr.shape)


@dataclass(frozen=True)
class Signal:
    """Samples on a uniform time grid: float64, time on the last axis, rate in Hz.

    ``Signal(samples, rate)`` holds a copy that no one can write, not even through ``setflags``: what the
    core hands to plugins (an actuator's input, a head site's row) is made this way, so that no plugin can
    change what another, the engine's record or a caller receives.
    """

    samples: np.ndarray
    rate_hz: float

    def __post_init__(self):
        self._hold(self.samples, self.rate_hz, copy=True)

    @classmethod
    def adopt(cls, samples: np.ndarray, rate_hz: float) -> "Signal":
        """A Signal over ``samples`` itself, not a copy (validated alike; the array is flagged read-only).

        For an array just made that nothing else holds, on its way between the core's own stages: a
        render's 48 kHz output is not copied once more there. The flag can be set back by whoever holds the
        array, so what goes to a plugin is a ``Signal(...)``.
        """
        signal = object.__new__(cls)
        signal._hold(samples, rate_hz, copy=False)
        return signal

    def _hold(self, samples, rate_hz, *, copy: bool) -> None:
        arr = valid_signal(samples, name="Signal.samples", ndim=(1, 2))
        rate = valid_rate(rate_hz, name="Signal.rate_hz")
        if copy:
            arr = _sealed(arr)
        else:
            arr.setflags(write=False)
        object.__setattr__(self, "samples", arr)
        object.__setattr__(self, "rate_hz", rate)

    @property
    def n_samples(self) -> int:
        return int(self.samples.shape[-1])

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.rate_hz

    @property
    def peak(self) -> float:
        return float(np.max(np.abs(self.samples)))

    def times(self) -> np.ndarray:
        """Sample times in seconds."""
        return np.arange(self.n_samples) / self.rate_hz

    def with_samples(self, samples) -> "Signal":
        return Signal(samples, self.rate_hz)
