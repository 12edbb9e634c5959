"""Light signal processing for the playback path (numpy only).

Playback must start fast, and importing ``scipy.signal`` alone costs about a
second. :func:`resample_poly` follows ``scipy.signal.resample_poly`` (Kaiser
beta 5 FIR, zero padding) and is tested against it (tests/test_dsp.py); it runs
the filter as one small matrix product per call, its polyphase plan computed
once per ratio; :func:`resample_rate` puts it behind a rate pair, and it is the
one resampler of the project (playback shaping and recorded-data preprocessing
alike). :func:`causal_butterworth` is a cascade of bilinear 2nd-order
Butterworth sections applied through their frequency response: causal, so a
signal that starts at zero comes out starting at zero (no pre-ringing click).
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

import numpy as np
from numpy.fft import irfft, rfft  # imported here, not lazily on the first impact


@lru_cache(maxsize=16)
def _polyphase_fir(up: int, down: int) -> np.ndarray:
    """Linear-phase low-pass FIR as resample_poly designs it, scaled by ``up``."""
    max_rate = max(up, down)
    half = 10 * max_rate
    n = np.arange(-half, half + 1)
    h = np.sinc(n / max_rate) * np.kaiser(2 * half + 1, 5.0)
    h = h / h.sum() * up
    h.setflags(write=False)
    return h


@lru_cache(maxsize=16)
def _polyphase_plan(up: int, down: int) -> tuple[np.ndarray, int]:
    """``(M, lo)``: output ``b * up + t`` is ``x[b * down + lo : b * down + lo + K] @ M[:, t]``."""
    h = _polyphase_fir(up, down)
    half = (h.size - 1) // 2
    taps = []
    for t in range(up):
        c, r = divmod(t * down + half, up)  # the input sample aligned with tap r of output t
        j = np.arange((h.size - 1 - r) // up + 1)
        taps.append((c - j, h[r + j * up]))
    lo = min(int(idx.min()) for idx, _ in taps)
    k = max(int(idx.max()) for idx, _ in taps) - lo + 1
    m = np.zeros((k, up))
    for t, (idx, weights) in enumerate(taps):
        m[idx - lo, t] = weights
    m.setflags(write=False)
    return m, lo


def resample_poly(x: np.ndarray, up: int, down: int) -> np.ndarray:
    """Resample along the last axis by ``up / down`` with a polyphase FIR (zero padding)."""
    g = math.gcd(up, down)
    up, down = up // g, down // g
    x = np.asarray(x, dtype=np.float64)
    if up == down == 1:
        return x.copy()
    m, lo = _polyphase_plan(up, down)
    n_in = x.shape[-1]
    n_out = -(-n_in * up // down)
    blocks = -(-n_out // up)
    left = max(0, -lo)
    right = max(0, (blocks - 1) * down + lo + m.shape[0] - n_in)
    padded = np.zeros(x.shape[:-1] + (left + n_in + right,))
    padded[..., left:left + n_in] = x
    # Block b reads padded[..., (lo + left) + b * down :][:K], a strided view (no copy); built directly, as
    # the sliding-window helpers cost more than the product itself on a 500-sample profile.
    item = padded.itemsize
    windows = np.ndarray(x.shape[:-1] + (blocks, m.shape[0]), dtype=padded.dtype, buffer=padded,
                         offset=(lo + left) * item, strides=padded.strides[:-1] + (down * item, item))
    return (windows @ m).reshape(x.shape[:-1] + (blocks * up,))[..., :n_out]


@lru_cache(maxsize=64)  # a Fraction's limit_denominator is slow for a per-impact path, and the rate pairs are few
def rate_ratio(from_hz: float, to_hz: float) -> Fraction:
    """``to_hz / from_hz`` as the nearest fraction with a denominator up to 1000 (``ValueError`` where that
    is more than 0.1 % off: a ratio of more than 1000 to 1 down)."""
    ratio = Fraction(to_hz / from_hz).limit_denominator(1000)
    if abs(float(ratio) * from_hz - to_hz) > 1e-3 * to_hz:
        raise ValueError(f"cannot resample from {from_hz:g} Hz to {to_hz:g} Hz: the ratio is past 1000 to 1 "
                         "(resample the recording to at most 1000 times the target rate first)")
    return ratio


def resample_rate(x: np.ndarray, from_hz: float, to_hz: float, *, axis: int = -1) -> np.ndarray:
    """``x`` sampled at ``from_hz`` resampled along ``axis`` by :func:`rate_ratio` (``from_hz * ratio``
    is the rate it then has, ``to_hz`` to within 0.1 %)."""
    if from_hz == to_hz:
        return np.array(x, dtype=np.float64)
    ratio = rate_ratio(from_hz, to_hz)
    x = np.asarray(x, dtype=np.float64)
    if axis in (-1, x.ndim - 1):
        return resample_poly(x, ratio.numerator, ratio.denominator)
    return np.moveaxis(resample_poly(np.moveaxis(x, axis, -1), ratio.numerator, ratio.denominator), -1, axis)


def _next_pow2(n: int) -> int:
    return 1 << (n - 1).bit_length()


def _sections(rate_hz: float, low_hz: float | None, high_hz: float | None) -> list[tuple[tuple, tuple]]:
    """Bilinear 2nd-order Butterworth sections ``(b, a)``: a high-pass at ``low_hz``, a low-pass at ``high_hz``."""
    out = []
    for edge, high_pass in ((low_hz, True), (high_hz, False)):
        if edge:
            k = math.tan(math.pi * edge / rate_hz)
            norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
            a = (1.0, 2.0 * (k * k - 1.0) * norm, (1.0 - math.sqrt(2.0) * k + k * k) * norm)
            b = (norm, -2.0 * norm, norm) if high_pass else (k * k * norm, 2.0 * k * k * norm, k * k * norm)
            out.append((b, a))
    return out


@lru_cache(maxsize=64)
def _ring(rate_hz: float, low_hz: float | None, high_hz: float | None) -> int:
    """Samples in which the sections' impulse response falls to e**-20 of its start: 20 time constants of
    the slowest pole in the z-plane (an edge near Nyquist puts a pole near -1 that rings far longer than
    ``1 / (2 pi edge)``)."""
    slowest = max(max(abs(r) for r in np.roots(a)) for _, a in _sections(rate_hz, low_hz, high_hz))
    return int(math.ceil(20.0 / -math.log(slowest)))


@lru_cache(maxsize=64)
def _response(rate_hz: float, low_hz: float | None, high_hz: float | None, nfft: int) -> np.ndarray:
    z = np.exp(-2j * np.pi * np.arange(nfft // 2 + 1) / nfft)
    h = np.ones_like(z)
    for b, a in _sections(rate_hz, low_hz, high_hz):
        h *= (b[0] + b[1] * z + b[2] * z * z) / (a[0] + a[1] * z + a[2] * z * z)
    h.setflags(write=False)
    return h


def causal_butterworth(x: np.ndarray, rate_hz: float, *, low_hz: float | None, high_hz: float | None) -> np.ndarray:
    """2nd-order Butterworth high-pass (``low_hz``) and/or low-pass (``high_hz``) along the last axis, causal.

    Applied as the sections' frequency response on a zero-padded FFT long enough
    for the impulse response to die out (no wrap-around); the output keeps the
    input's length.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.shape[-1]
    nfft = _next_pow2(n + _ring(rate_hz, low_hz, high_hz))
    return irfft(rfft(x, nfft) * _response(rate_hz, low_hz, high_hz, nfft), nfft)[..., :n]


@lru_cache(maxsize=32)
def _ramp(count: int) -> np.ndarray:
    """Raised-cosine fade-in of ``count`` samples: 0 ... just under 1."""
    ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(count) / count)
    ramp.setflags(write=False)
    return ramp


def taper(x: np.ndarray, rate_hz: float, *, fade_in_s: float, fade_out_s: float) -> np.ndarray:
    """``x`` with raised-cosine fades at both ends, so that it starts and ends at zero."""
    x = np.array(x, dtype=np.float64)
    n = x.shape[-1]
    for count, at_end in ((int(round(fade_in_s * rate_hz)), False), (int(round(fade_out_s * rate_hz)), True)):
        count = min(count, n // 2)
        if count:
            ramp = _ramp(count)
            if at_end:
                x[..., n - count:] *= ramp[::-1]
            else:
                x[..., :count] *= ramp
    return x
