"""How alike a predicted impact profile is to a recorded one, and how far a mean of recorded drops can be trusted.

- ``rmse``: root-mean-square difference (g); rewards a blurred average.
- ``log_spectral_distance``: RMS difference of the two magnitude spectra in dB over
  20-500 Hz (the band the paper's preprocessing keeps below Nyquist). A blurred
  average loses high-frequency energy and pays for it here.
- ``peak_error_db``: ``20 log10(peak(pred) / peak(truth))``; a blurred average has
  a lower peak.
- ``mean_sampling_rmse``: the sampling error of the mean of a velocity's drops.

Spectra below ``-60 dB`` of the larger of the two peaks are treated as that floor,
so silence in both does not count as a difference. All take ``(..., N)`` arrays
(time last) and return ``(...)``.
"""

from __future__ import annotations

import numpy as np

from ..signal import valid_number, valid_signal

BAND_HZ = (20.0, 500.0)
FLOOR_DB = -60.0


def _pair(pred, truth) -> tuple[np.ndarray, np.ndarray]:
    a = valid_signal(pred, name="prediction")
    b = valid_signal(truth, name="truth")
    return np.broadcast_arrays(a, b)


def rmse(pred, truth) -> np.ndarray:
    """Root-mean-square difference along time."""
    a, b = _pair(pred, truth)
    return np.sqrt(np.mean((a - b) ** 2, axis=-1))


def log_spectral_distance(pred, truth, *, rate_hz: float = 1000.0, band_hz: tuple[float, float] = BAND_HZ) -> np.ndarray:
    """RMS of the difference of the magnitude spectra in dB, over the DFT bins in ``band_hz``."""
    a, b = _pair(pred, truth)
    rate = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    f = np.fft.rfftfreq(a.shape[-1], 1.0 / rate)
    sel = (f >= band_hz[0]) & (f <= band_hz[1])
    sa, sb = np.abs(np.fft.rfft(a, axis=-1))[..., sel], np.abs(np.fft.rfft(b, axis=-1))[..., sel]
    floor = 10 ** (FLOOR_DB / 20) * np.maximum(sa.max(axis=-1), sb.max(axis=-1))[..., None]
    floor = np.where(floor > 0, floor, 1.0)
    diff = 20.0 * np.log10((sa + floor) / (sb + floor))
    return np.sqrt(np.mean(diff ** 2, axis=-1))


def peak_error_db(pred, truth) -> np.ndarray:
    """``20 log10(max|pred| / max|truth|)``: negative when the prediction's peak is too low."""
    a, b = _pair(pred, truth)
    pa, pb = np.abs(a).max(axis=-1), np.abs(b).max(axis=-1)
    tiny = 1e-12
    return 20.0 * np.log10(np.maximum(pa, tiny) / np.maximum(pb, tiny))


def mean_sampling_rmse(drops) -> float:
    """The sampling error of the mean of ``drops`` ``(D, N)``: ``sqrt(mean_t s_t^2 / D)`` (``s_t``: sample SD).

    The expected RMSE, against the mean of these D drops, of a prediction equal to the true
    population mean (a method that knew the velocity's response exactly, less its drop-to-drop
    noise): the floor of the "RMSE vs the held-out drops' mean" measure. With ``ddof=1`` its
    square is unbiased; a bootstrap of the drops estimates the same quantity ((D-1)/D of the square).
    """
    d = valid_signal(drops, name="drops", ndim=2)
    if len(d) < 2:
        return float("nan")
    centred = d.astype(np.float64) - d[0]  # shift-invariant; exactly 0 for identical drops
    return float(np.sqrt(np.mean(np.var(centred, axis=0, ddof=1)) / len(d)))
