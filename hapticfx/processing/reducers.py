"""Reducers from 3-axis to 1-axis acceleration: ``max-min`` (paper Eq. 8) and ``dft321``.

Both take ``(..., N, 3)`` and return ``(..., N)``, vectorised over any leading axes.
:func:`reduce_checked` runs any registered reducer and refuses an answer that is not that.
"""

from __future__ import annotations

import numpy as np

from ..errors import PluginError, SignalError
from ..interfaces import Reducer
from ..signal import valid_signal


def _xyz(xyz) -> np.ndarray:
    arr = valid_signal(xyz, name="3-axis acceleration")
    if arr.ndim < 2 or arr.shape[-1] != 3:
        raise SignalError(f"3-axis acceleration must have shape (..., samples, 3), got {arr.shape}")
    return arr


def max_min(xyz) -> np.ndarray:
    """Paper Eq. 8: per sample, the largest axis value if any axis is >= 0, else the smallest."""
    arr = _xyz(xyz)
    x, y, z = arr[..., 0], arr[..., 1], arr[..., 2]
    # "any axis >= 0" is the same test as "the largest axis >= 0"; element-wise
    # ufuncs over the three columns beat reductions along a length-3 axis.
    largest = np.maximum(np.maximum(x, y), z)
    return np.where(largest >= 0, largest, np.minimum(np.minimum(x, y), z))


# A spectrum of N samples of at most p is at most N p; below this, the sum of three axes' squared spectra
# (at most 3 (N p)^2) stays finite; above _SQUARES_TINY, no square of a sample's size underflows to zero.
_SQUARES_SAFE = np.sqrt(np.finfo(np.float64).max) / 4
_SQUARES_TINY = np.sqrt(np.finfo(np.float64).tiny) * 2**30


def _dft321(arr: np.ndarray) -> np.ndarray:
    spectra = np.fft.rfft(arr, axis=-2)
    magnitude = np.sqrt(np.sum(spectra.real ** 2 + spectra.imag ** 2, axis=-1))
    phase = np.angle(spectra.sum(axis=-1))
    return np.fft.irfft(magnitude * np.exp(1j * phase), n=arr.shape[-2], axis=-1)


def dft321(xyz) -> np.ndarray:
    """DFT321 (paper Eqs. 12-14; Landin et al. 2010).

    Magnitude: root-sum-square of the three axes' spectra. Phase: the angle of
    the summed spectra (``np.angle``, defined in all four quadrants). The
    length is kept; a single non-zero axis comes back unchanged.

    A signal so large that the squared spectra would overflow (above about 1e153 / N), or so small
    that they would underflow to zero (below about 1e-145), is reduced scaled by a power of two,
    which is exact, and scaled back; every other signal is reduced as it is, bit for bit. A result
    beyond the float64 range (``sqrt(3)`` times the largest float, say) is a :class:`SignalError`.
    No samples give no samples.
    """
    arr = _xyz(xyz)
    if arr.shape[-2] == 0:
        return np.zeros(arr.shape[:-1])
    safe = _SQUARES_SAFE / arr.shape[-2]
    peak = np.max(np.abs(arr), axis=(-2, -1), keepdims=True)
    outside = (peak > safe) | ((peak > 0) & (peak < _SQUARES_TINY))
    if not outside.any():
        return _dft321(arr)
    exponent = np.where(outside, np.frexp(peak)[1], 0)[..., 0]  # each such signal's peak brought to [0.5, 1)
    with np.errstate(over="ignore"):
        out = np.ldexp(_dft321(np.ldexp(arr, -exponent[..., None])), exponent)
    if not np.all(np.isfinite(out)):
        raise SignalError(f"dft321 of a signal peaking at {peak.max():.2g} exceeds the float64 range")
    return out


def reduce_checked(reducer: Reducer, name: str, xyz: np.ndarray, *, source: str, label: str) -> np.ndarray:
    """``reducer`` (registered as ``name``) applied to the float64 ``xyz (..., N, 3)`` of ``label``, such as
    "object 'wood-beam'": a plugin's answer must be a finite float64 array of shape ``(..., N)``. Anything
    else is a :class:`PluginError` naming ``source`` (the dataset), the reducer and what was expected."""
    out = reducer.reduce(xyz)
    want = xyz.shape[:-1]
    if not isinstance(out, np.ndarray):
        got = f"a {type(out).__name__}"
    elif out.dtype != np.float64:
        got = f"{out.dtype} values"
    elif out.shape != want:
        got = f"shape {out.shape}"
    elif not np.all(np.isfinite(out)):
        got = f"{np.count_nonzero(~np.isfinite(out))} non-finite value(s)"
    else:
        return out
    raise PluginError(f"reducer {name!r} returned {got} for {label}; expected finite float64 values of shape {want}",
                      source=source)


class MaxMin(Reducer):
    """``max-min``: the paper's max-min extraction (Eq. 8)."""

    name = "max-min"

    def reduce(self, xyz: np.ndarray) -> np.ndarray:
        return max_min(xyz)


class DFT321(Reducer):
    """``dft321``: spectral-energy-preserving reduction (Landin et al. 2010)."""

    name = "dft321"

    def reduce(self, xyz: np.ndarray) -> np.ndarray:
        return dft321(xyz)
