"""How well a 1D signal stands for a 3-axis recording: spectral, temporal and peak match.

All three are ``1 - D(a, b)`` with the normalised absolute difference
``D(a, b) = sum|a - b| / sum(a + b)`` of two non-negative curves: 1 means
identical, 0 means no overlap at all; two all-zero curves match (1). The curves:

- ``spectral_match``: ``a`` = magnitude spectrum ``|DFT(x)|`` of the 1D signal,
  ``b`` = root-sum-square spectrum ``sqrt(|DFT(ax)|^2 + |DFT(ay)|^2 + |DFT(az)|^2)``,
  both on the DFT bins in ``band_hz`` (20-500 Hz). DFT321 scores 1 by construction.
- ``welch_spectral_match``: the same on Welch amplitude spectra (square root of
  the PSD; Hann segments of ``segment`` samples, half overlap; 3-axis: sum of the
  axes' PSDs). DFT321 keeps the whole-window spectrum but not the local ones.
- ``temporal_match``: ``a`` = energy envelope of the 1D signal, ``b`` = energy
  envelope of the 3-axis vector magnitude; envelope ``e(t) = sqrt(mean of s^2 over
  a centred window of envelope_s)`` (``s^2 = x^2``, resp. ``ax^2 + ay^2 + az^2``).
- ``peak_match``: ``min(p1, p3) / max(p1, p3)`` with ``p1 = max|x|`` and ``p3`` the
  peak of the vector magnitude (how much of the impact's peak survives).

Inputs: ``x (..., N)`` and ``xyz (..., N, 3)``; results ``(...)``. See docs/data.md.
"""

from __future__ import annotations

import numpy as np

from ..errors import SignalError
from ..signal import valid_number, valid_signal


def _pair(x, xyz) -> tuple[np.ndarray, np.ndarray]:
    one = valid_signal(x, name="1D signal")
    three = valid_signal(xyz, name="3-axis signal")
    if three.ndim < 2 or three.shape[-1] != 3 or three.shape[:-1] != one.shape:
        raise SignalError(f"1D signal {one.shape} and 3-axis signal {three.shape} must be (..., N) and (..., N, 3)")
    return one, three


def match(a, b, *, axis: int = -1) -> np.ndarray:
    """``1 - sum|a - b| / sum(a + b)`` along ``axis`` for non-negative curves (1 where both are zero)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    den = np.sum(a + b, axis=axis)
    num = np.sum(np.abs(a - b), axis=axis)
    safe = np.where(den > 0, den, 1.0)
    return np.where(den > 0, 1.0 - num / safe, 1.0)


def _band(n: int, rate_hz: float, band_hz: tuple[float, float]) -> np.ndarray:
    f = np.fft.rfftfreq(n, 1.0 / rate_hz)
    lo, hi = band_hz
    sel = (f >= lo) & (f <= hi)
    if not sel.any():
        raise SignalError(f"no frequency bin of a {n}-sample signal at {rate_hz} Hz lies in {lo}-{hi} Hz")
    return sel


def spectral_match(x, xyz, *, rate_hz: float = 1000.0, band_hz: tuple[float, float] = (20.0, 500.0)) -> np.ndarray:
    """Match of ``|DFT(x)|`` to the root-sum-square spectrum of the three axes over ``band_hz``."""
    one, three = _pair(x, xyz)
    rate = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    sel = _band(one.shape[-1], rate, band_hz)
    a = np.abs(np.fft.rfft(one, axis=-1))[..., sel]
    spectra = np.fft.rfft(three, axis=-2)
    b = np.sqrt(np.sum(np.abs(spectra) ** 2, axis=-1))[..., sel]
    return match(a, b)


def welch_spectral_match(x, xyz, *, rate_hz: float = 1000.0, band_hz: tuple[float, float] = (20.0, 500.0),
                         segment: int = 64) -> np.ndarray:
    """Match of Welch amplitude spectra (1D vs. sum of the axes' PSDs) over ``band_hz``."""
    from scipy.signal import welch

    one, three = _pair(x, xyz)
    rate = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    seg = min(int(segment), one.shape[-1])
    f, p1 = welch(one, fs=rate, nperseg=seg, axis=-1)
    _, p3 = welch(three, fs=rate, nperseg=seg, axis=-2)
    sel = (f >= band_hz[0]) & (f <= band_hz[1])
    return match(np.sqrt(p1[..., sel]), np.sqrt(p3.sum(axis=-1)[..., sel]))


def envelope(power, *, rate_hz: float, envelope_s: float = 0.01) -> np.ndarray:
    """``sqrt`` of the centred moving mean of ``power`` (``s^2``) over ``envelope_s`` (last axis)."""
    from scipy.ndimage import uniform_filter1d

    width = max(1, int(round(envelope_s * rate_hz)))
    return np.sqrt(np.maximum(uniform_filter1d(power, width, axis=-1, mode="constant"), 0.0))


def temporal_match(x, xyz, *, rate_hz: float = 1000.0, envelope_s: float = 0.01) -> np.ndarray:
    """Match of the 1D signal's energy envelope to that of the 3-axis vector magnitude."""
    one, three = _pair(x, xyz)
    rate = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    win = valid_number(envelope_s, name="envelope_s", minimum=0.0)
    return match(envelope(one ** 2, rate_hz=rate, envelope_s=win),
                 envelope(np.sum(three ** 2, axis=-1), rate_hz=rate, envelope_s=win))


def peak_match(x, xyz) -> np.ndarray:
    """``min/max`` of the 1D peak ``max|x|`` and the peak of the 3-axis vector magnitude."""
    one, three = _pair(x, xyz)
    p1 = np.max(np.abs(one), axis=-1)
    p3 = np.max(np.sqrt(np.sum(three ** 2, axis=-1)), axis=-1)
    hi = np.maximum(p1, p3)
    return np.where(hi > 0, np.minimum(p1, p3) / np.where(hi > 0, hi, 1.0), 1.0)
