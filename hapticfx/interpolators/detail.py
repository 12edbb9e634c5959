"""The drop-to-drop detail a mean of drops loses, given back to a centre in part.

Each drop of a velocity rings a little differently: above a hundred hertz or so
their fine detail is out of phase from drop to drop, and their mean keeps little
of it. A profile built from drop means is then duller than any recorded drop
(less energy where the skin is most sensitive, 150-300 Hz), and a log-spectral
or perceptual measure against every drop scores it below the blend of two
recorded drops. Per recorded velocity ``k`` the power spectra of its drops
``D_k(f)`` (their mean) and of its centre ``C_k(f)`` (both smoothed over
:data:`SMOOTH_HZ`) say what the mean lost; between ``k`` and ``k + 1`` at ``w``
the centre is filtered, zero phase, by::

    gain(f) = clip( ((1 - w) D_k + w D_k+1) / ((1 - w) C_k + w C_k+1), 1, MAX_GAIN ) ^ (alpha / 2)

``alpha`` 0 leaves the centre as it is (the least squares choice against the
drop mean); 1 gives it the drops' mean power. The cost in RMSE against the
drop mean grows with ``alpha`` squared at first, the spectral gain with
``alpha``; :mod:`hapticfx.interpolators.ensemble_warp` chooses it from the
training data.
"""

from __future__ import annotations

import numpy as np

ALPHAS = (0.0, 0.25, 0.5, 0.75, 1.0)
SMOOTH_HZ = 10.0   # half-width of the Hann window the power spectra are smoothed with
MAX_GAIN = 16.0    # in power: at most 12 dB where a centre kept almost nothing


def n_fft(n_samples: int) -> int:
    """The FFT length for profiles of ``n_samples``: a power of two at least twice as long (a filter's tail
    never wraps onto the profile)."""
    return 1 << int(np.ceil(np.log2(2 * max(n_samples, 1))))


def power(profiles: np.ndarray, rate_hz: float) -> np.ndarray:
    """Smoothed power spectra of ``profiles`` ``(..., N)`` -> ``(..., n_fft(N) // 2 + 1)``."""
    x = np.asarray(profiles, dtype=np.float64)
    nfft = n_fft(x.shape[-1])
    p = np.abs(np.fft.rfft(x, nfft, axis=-1)) ** 2
    half = max(1, int(round(SMOOTH_HZ * nfft / rate_hz)))
    k = np.hanning(2 * half + 3)[1:-1]
    k /= k.sum()
    rows = np.pad(p.reshape(-1, p.shape[-1]), [(0, 0), (half, half)], mode="reflect")
    return np.stack([np.convolve(row, k, mode="valid") for row in rows]).reshape(p.shape)


def gain(drops_lo, drops_hi, centre_lo, centre_hi, w: float, alpha: float) -> np.ndarray:
    """The amplitude gain per rfft bin at ``w`` between two velocities (their drops' and centres' smoothed
    power, :func:`power`)."""
    lost = ((1 - w) * drops_lo + w * drops_hi) / np.maximum((1 - w) * centre_lo + w * centre_hi, 1e-300)
    return np.clip(lost, 1.0, MAX_GAIN) ** (alpha / 2)


def restore(centre: np.ndarray, g: np.ndarray) -> np.ndarray:
    """``centre`` filtered by the gain ``g`` (zero phase; the FFT length of :func:`n_fft`)."""
    n = len(centre)
    nfft = 2 * (len(g) - 1)
    return np.fft.irfft(np.fft.rfft(centre, nfft) * g, nfft)[:n]


__all__ = ["ALPHAS", "MAX_GAIN", "SMOOTH_HZ", "gain", "n_fft", "power", "restore"]
