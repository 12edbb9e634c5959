"""Light signal processing for the playback path (numpy only).

Playback must start fast, and importing ``scipy.signal`` alone costs about a
second. These two operations follow scipy's designs and are tested against
them (tests/test_dsp.py): :func:`resample_poly` matches
``scipy.signal.resample_poly`` (Kaiser beta 5 FIR, zero padding), and
:func:`zero_phase_butterworth` applies the magnitude-squared response of a
bilinear Butterworth filter, as ``sosfiltfilt`` does in steady state.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np


@lru_cache(maxsize=32)
def _polyphase_fir(up: int, down: int) -> np.ndarray:
    """Linear-phase low-pass FIR as resample_poly designs it, scaled by ``up``."""
    max_rate = max(up, down)
    half = 10 * max_rate
    n = np.arange(-half, half + 1)
    h = np.sinc(n / max_rate) * np.kaiser(2 * half + 1, 5.0)
    h = h / h.sum() * up
    h.setflags(write=False)
    return h


def _next_pow2(n: int) -> int:
    return 1 << (n - 1).bit_length()


def resample_poly(x: np.ndarray, up: int, down: int) -> np.ndarray:
    """Resample along the last axis by ``up / down`` with a polyphase FIR (zero padding)."""
    g = math.gcd(up, down)
    up, down = up // g, down // g
    x = np.asarray(x, dtype=np.float64)
    if up == down == 1:
        return x.copy()
    h = _polyphase_fir(up, down)
    half = (h.size - 1) // 2
    n_in = x.shape[-1]
    n_out = -(-n_in * up // down)
    stuffed = np.zeros(x.shape[:-1] + (n_in * up,))
    stuffed[..., ::up] = x
    n_full = stuffed.shape[-1] + h.size - 1
    nfft = _next_pow2(n_full)
    full = np.fft.irfft(np.fft.rfft(stuffed, nfft) * np.fft.rfft(h, nfft), nfft)[..., :n_full]
    return full[..., half : half + n_out * down : down][..., :n_out]


def butterworth_power(freqs_hz: np.ndarray, rate_hz: float, *, low_hz: float | None, high_hz: float | None,
                      order: int) -> np.ndarray:
    """|H(f)|^2 of a digital (bilinear) Butterworth high-, low- or band-pass of ``order``."""
    w = np.tan(np.pi * np.clip(freqs_hz / rate_hz, 0.0, 0.5 - 1e-12))
    with np.errstate(divide="ignore", invalid="ignore"):
        if low_hz and high_hz:
            wl, wh = np.tan(np.pi * low_hz / rate_hz), np.tan(np.pi * high_hz / rate_hz)
            ratio = (w * w - wl * wh) / ((wh - wl) * w)
        elif low_hz:
            ratio = np.tan(np.pi * low_hz / rate_hz) / w
        elif high_hz:
            ratio = w / np.tan(np.pi * high_hz / rate_hz)
        else:
            return np.ones_like(w)
        power = 1.0 / (1.0 + np.abs(ratio) ** (2 * order))
    return np.nan_to_num(power, nan=0.0)


def zero_phase_butterworth(x: np.ndarray, rate_hz: float, *, low_hz: float | None, high_hz: float | None,
                           order: int = 2) -> np.ndarray:
    """Forward-backward Butterworth along the last axis, applied in the frequency domain.

    The signal is zero-padded to twice its length so the response does not wrap around.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.shape[-1]
    nfft = _next_pow2(2 * n)
    gain = butterworth_power(np.fft.rfftfreq(nfft, 1.0 / rate_hz), rate_hz, low_hz=low_hz, high_hz=high_hz,
                             order=order)
    return np.fft.irfft(np.fft.rfft(x, nfft) * gain, nfft)[..., :n]
