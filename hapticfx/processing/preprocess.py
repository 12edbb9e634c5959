"""Preprocessing of 3-axis impact recordings: high-pass, resampling, trigger alignment, windows.

The chain (paper Sect. 4.3) for recordings ``(..., N, 3)`` in g at any rate:

1. 20 Hz Butterworth high-pass, second-order sections, run forwards and
   backwards (zero phase), at the recording's own rate: removes gravity and
   the static offset of the sensor.
2. Polyphase resampling to 1 kHz when the recording was made at another rate.
3. Trigger alignment: the window starts ``pre_trigger_s`` before the first
   sample whose 3-axis vector magnitude reaches ``trigger_fraction`` of its peak.
4. A 500-sample window (zero-padded if the recording ends early).

Time is on axis ``-2`` of a 3-axis array (samples x axes) and on the last axis
of a 1D signal.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..dsp import resample_rate
from ..errors import SignalError
from ..signal import valid_number, valid_signal


# A window may run past a short recording (zeros), up to this many times the recording's length.
MAX_PADDING = 4


@dataclass(frozen=True)
class Preprocessing:
    """Parameters of the preprocessing chain; stored in a dataset's metadata."""

    cutoff_hz: float = 20.0
    order: int = 4
    rate_hz: float = 1000.0
    n_samples: int = 500
    pre_trigger_s: float = 0.01
    trigger_fraction: float = 0.1

    def __post_init__(self):
        valid_number(self.cutoff_hz, name="cutoff_hz", minimum=1e-3, maximum=1e5)
        valid_number(self.rate_hz, name="rate_hz", minimum=1.0, maximum=1e6)
        valid_number(self.pre_trigger_s, name="pre_trigger_s", minimum=0.0, maximum=10.0)
        valid_number(self.trigger_fraction, name="trigger_fraction", minimum=1e-6, maximum=1.0)
        order = valid_number(self.order, name="order", minimum=1, maximum=12)
        if int(order) != order:
            raise SignalError(f"order must be an integer in 1..12, got {self.order!r}")
        n = valid_number(self.n_samples, name="n_samples", minimum=8, maximum=1e6)
        if int(n) != n:
            raise SignalError(f"n_samples must be an integer in 8..1e6, got {self.n_samples!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "Preprocessing":
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


def highpass_sos(rate_hz: float, *, cutoff_hz: float = 20.0, order: int = 4) -> np.ndarray:
    """Butterworth high-pass in second-order sections for ``rate_hz``."""
    from scipy.signal import butter

    rate = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    cut = valid_number(cutoff_hz, name="cutoff_hz", minimum=1e-9)
    if cut >= rate / 2:
        raise SignalError(f"cutoff {cut} Hz must be below the Nyquist frequency {rate / 2} Hz")
    return butter(int(order), cut, btype="highpass", fs=rate, output="sos")


def highpass(x, rate_hz: float, *, cutoff_hz: float = 20.0, order: int = 4, axis: int = -1) -> np.ndarray:
    """Zero-phase Butterworth high-pass of ``x`` along ``axis`` (SOS, forwards-backwards).

    Recordings shorter than the filter's edge padding are padded as far as they allow.
    """
    from scipy.signal import sosfiltfilt

    arr = valid_signal(x, name="signal")
    sos = highpass_sos(rate_hz, cutoff_hz=cutoff_hz, order=order)
    n = arr.shape[axis]
    # The default padding (3 * (2 * sections + 1)) must be shorter than the signal.
    padlen = min(3 * (2 * len(sos) + 1), n - 1)
    # Scale to unit peak so that 1e-12 g and 1e6 g inputs go through the same float range.
    scale = float(np.max(np.abs(arr)))
    if scale == 0.0:
        return np.zeros_like(arr)
    return sosfiltfilt(sos, arr / scale, axis=axis, padlen=padlen) * scale


def resample(x, from_hz: float, to_hz: float, *, axis: int = -1) -> np.ndarray:
    """Polyphase resampling of ``x`` along ``axis`` (the ratio is approximated to 1/1000), by
    :func:`hapticfx.dsp.resample_rate`, the resampler of the playback path."""
    arr = valid_signal(x, name="signal")
    src = valid_number(from_hz, name="from_hz", minimum=1e-9)
    dst = valid_number(to_hz, name="to_hz", minimum=1e-9)
    try:
        return resample_rate(arr, src, dst, axis=axis)
    except ValueError as exc:
        raise SignalError(str(exc)) from None


def trigger_onsets(xyz, *, fraction: float = 0.1) -> np.ndarray:
    """Index of the first sample whose vector magnitude reaches ``fraction`` of its peak.

    ``xyz`` is ``(..., N, 3)``; returns ``(...)`` integers (0 for silent recordings).
    """
    arr = valid_signal(xyz, name="recording")
    if arr.ndim < 2 or arr.shape[-1] != 3:
        raise SignalError(f"recording must have shape (..., samples, 3), got {arr.shape}")
    mag = np.hypot(np.hypot(arr[..., 0], arr[..., 1]), arr[..., 2])  # no square overflows (1e200 g stays finite)
    peak = mag.max(axis=-1, keepdims=True)
    above = (mag >= fraction * peak) & (peak > 0)
    return np.where(above.any(axis=-1), above.argmax(axis=-1), 0)


def windows(xyz, onsets, *, n_samples: int, pre_samples: int) -> np.ndarray:
    """Cut ``n_samples`` from each recording starting ``pre_samples`` before its onset.

    Samples outside the recording are zeros. ``xyz`` ``(..., N, 3)``, ``onsets`` ``(...)``.
    Only the result is allocated (a window's memory does not multiply with index arrays).
    """
    arr = np.asarray(xyz, dtype=np.float64)
    n, size = arr.shape[-2], int(n_samples)
    starts = np.broadcast_to(np.asarray(onsets, dtype=np.int64) - int(pre_samples), arr.shape[:-2]).reshape(-1)
    flat = arr.reshape(-1, n, arr.shape[-1])
    out = np.zeros((flat.shape[0], size, arr.shape[-1]))
    for k, start in enumerate(starts.tolist()):
        lo, hi = max(start, 0), min(start + size, n)
        if lo < hi:
            out[k, lo - start:hi - start] = flat[k, lo:hi]
    return out.reshape(arr.shape[:-2] + (size, arr.shape[-1]))


def preprocess(accel_g, rate_hz: float, *, params: Preprocessing | None = None) -> np.ndarray:
    """The full chain: raw ``(..., N, 3)`` g at ``rate_hz`` to aligned ``(..., n_samples, 3)`` at 1 kHz."""
    p = params or Preprocessing()
    arr = valid_signal(accel_g, name="recording")
    if arr.ndim < 2 or arr.shape[-1] != 3:
        raise SignalError(f"recording must have shape (..., samples, 3), got {arr.shape}")
    if arr.shape[-2] < 4:
        raise SignalError(f"recording has {arr.shape[-2]} samples; the high-pass filter needs at least 4")
    filtered = highpass(arr, rate_hz, cutoff_hz=p.cutoff_hz, order=p.order, axis=-2)
    filtered = resample(filtered, rate_hz, p.rate_hz, axis=-2)
    if p.n_samples > MAX_PADDING * filtered.shape[-2]:  # mostly zeros, and memory that grows with n_samples
        raise SignalError(f"n_samples {p.n_samples} is more than {MAX_PADDING} times the recordings' length "
                          f"({filtered.shape[-2]} samples at {p.rate_hz:g} Hz)")
    onsets = trigger_onsets(filtered, fraction=p.trigger_fraction)
    pre = int(round(p.pre_trigger_s * p.rate_hz))
    return windows(filtered, onsets, n_samples=p.n_samples, pre_samples=pre)
