"""Perceptual similarity of vibrotactile signals: ST-SIM and SPQI, as the haptic-codec literature defines them.

- **ST-SIM** (spectral-temporal similarity; Hassen and Steinbach, IEEE Trans. Haptics 2019):
  ``temporal^eta * spectral^(1 - eta)``, eta = 2/3. Per block of 512 samples, *temporal* is
  the normalised correlation ``sum(r d) / sum(r^2)`` of the zero-mean, unit-variance blocks
  and *spectral* the same of the "spectral supports" ``Phi(S / 12)`` (normal CDF) of the
  perceptual spectra ``S`` (DCT magnitude in dB above the vibrotactile detection threshold);
  both are averaged over blocks. 1 is identical.
- **SPQI** (spectral perceptual quality index; Noll et al., IEEE Haptics Symposium 2022):
  per block ``(1 - tanh(0.3 E + 2)) / 2`` with ``E`` the perceptual spectra's power
  difference relative to the reference's, in dB; averaged over blocks. 1 is identical.

The definitions follow the authors' reference implementation (the ``vibromaf`` package; the
tests compare with it where it is right), with two corrections:

- The temporal similarity of anti-correlated signals is negative, and a negative number
  to the power 2/3 is complex in Python: ``vibromaf`` returns a complex ST-SIM for a signal
  shifted by a few samples. Its real part, ``|x|^(2/3) cos(2 pi / 3)``, means nothing; a
  negative correlation is no similarity, so it is taken as 0 (then ST-SIM is 0).
- The detection threshold is evaluated at the DCT bins' own frequencies ``k fs / (2 N)``
  for the signal's rate ``fs``; ``vibromaf``'s default builder lays it on an 8 kHz grid
  whatever the signal's rate.

Our profiles are 1 kHz and 500 samples, shorter than one block; the metrics were made for
2.8 kHz signals. :func:`prepare` resamples to 2.8 kHz with the project's polyphase filter
(:func:`hapticfx.dsp.resample_rate`, up 14 down 5, Kaiser-windowed FIR: no content is added
above the original 500 Hz Nyquist) and pads with zeros to whole blocks (1400 samples ->
3 blocks; the padding is silence after the window, the same in both signals). Signals are
in g; the threshold (dB) is taken against m/s^2, so profiles are converted first.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.fft import dct
from scipy.special import ndtr

from ..dsp import resample_rate
from ..signal import valid_number, valid_signal

BLOCK = 512
RATE_HZ = 2800.0
G = 9.80665
STSIM_ETA = 2 / 3
SPQI_ETA, SPQI_THRESHOLD = 0.3, -2.0
_EPS = np.finfo(float).eps


def prepare(profile, *, rate_hz: float) -> np.ndarray:
    """``profile`` (g, at ``rate_hz``) as the metrics take it: m/s^2 at 2.8 kHz, zero-padded to whole blocks."""
    x = valid_signal(profile, name="profile", ndim=1).astype(np.float64) * G
    rate = valid_number(rate_hz, name="rate_hz", minimum=1.0)
    x = resample_rate(x, rate, RATE_HZ)
    return np.pad(x, (0, -len(x) % BLOCK))


def threshold_db(rate_hz: float = RATE_HZ, block: int = BLOCK) -> np.ndarray:
    """The vibrotactile detection threshold (dB) at the ``block`` DCT bins of a signal sampled at ``rate_hz``;
    constant above the frequency where it first turns positive, as in the reference implementation."""
    f = np.linspace(0.0, rate_hz, 2 * block)[:block]
    y = 1 / 550
    x0 = 1 - 250 * y  # the curve's minimum, -77 dB, lies at 250 Hz
    t = np.abs(62 / np.log10(x0) ** 2 * np.log10(y * f + x0) ** 2) - 77
    t[int(np.argmax(t > 0)):] = t[int(np.argmax(t > 0))]
    return t


@lru_cache(maxsize=8)
def _threshold(rate_hz: float, block: int) -> np.ndarray:
    t = threshold_db(rate_hz, block)
    t.flags.writeable = False
    return t


def _blocks(x: np.ndarray) -> np.ndarray:
    return x[..., : x.shape[-1] // BLOCK * BLOCK].reshape(*x.shape[:-1], -1, BLOCK)


def perceptual_spectrum(x: np.ndarray, rate_hz: float = RATE_HZ) -> np.ndarray:
    """Per block (of each signal along the last axis): DCT magnitude (dB) above the detection threshold."""
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(dct(_blocks(x), norm="ortho", axis=-1))) - _threshold(float(rate_hz), BLOCK)


def _similarity(ref: np.ndarray, dist: np.ndarray) -> np.ndarray:
    return np.mean(np.sum(ref * dist, axis=-1) / (np.sum(ref**2, axis=-1) + _EPS), axis=-1)


def _normalised(blocks: np.ndarray) -> np.ndarray:
    return (blocks - blocks.mean(axis=-1, keepdims=True)) / (blocks.std(axis=-1, keepdims=True) + _EPS)


def _pairs(distorted, reference) -> tuple[np.ndarray, np.ndarray]:
    return np.broadcast_arrays(np.asarray(distorted, dtype=np.float64), np.asarray(reference, dtype=np.float64))


def _per_pair(values: np.ndarray, dist: np.ndarray, ref: np.ndarray) -> float | np.ndarray:
    """``values``, with 1 where the pair is identical; a float for one pair."""
    out = np.where(np.all(dist == ref, axis=-1), 1.0, values)
    return float(out) if out.ndim == 0 else out


def st_sim(distorted, reference, *, rate_hz: float = RATE_HZ, eta: float = STSIM_ETA) -> float | np.ndarray:
    """ST-SIM of ``distorted`` against ``reference`` (prepared signals of equal length); 1 is identical.
    Arrays ``(..., L)`` broadcast against each other and give one value per pair."""
    dist, ref = _pairs(distorted, reference)
    spectral = _similarity(ndtr(perceptual_spectrum(ref, rate_hz) / 12), ndtr(perceptual_spectrum(dist, rate_hz) / 12))
    temporal = np.maximum(_similarity(_normalised(_blocks(ref)), _normalised(_blocks(dist))), 0.0)
    return _per_pair(temporal**eta * spectral ** (1 - eta), dist, ref)


def spqi(distorted, reference, *, rate_hz: float = RATE_HZ, eta: float = SPQI_ETA,
         threshold: float = SPQI_THRESHOLD) -> float | np.ndarray:
    """SPQI of ``distorted`` against ``reference`` (prepared signals of equal length); 1 is identical.
    Arrays ``(..., L)`` broadcast against each other and give one value per pair."""
    dist, ref = _pairs(distorted, reference)
    p_ref = 10 ** (perceptual_spectrum(ref, rate_hz) / 10)
    p_dist = 10 ** (perceptual_spectrum(dist, rate_hz) / 10)
    with np.errstate(divide="ignore"):
        error = 10 * np.log10(np.sum(np.abs(p_ref - p_dist), axis=-1) / (np.sum(p_ref, axis=-1) + _EPS))
    return _per_pair(np.mean((1 - np.tanh(eta * error - threshold)) / 2, axis=-1), dist, ref)


def scores(pred, truths, *, rate_hz: float) -> dict[str, float]:
    """Mean ST-SIM and SPQI of profile ``pred`` against each of ``truths`` ``(D, N)`` (1 is perfect)."""
    p = prepare(pred, rate_hz=rate_hz)
    refs = np.array([prepare(t, rate_hz=rate_hz) for t in np.atleast_2d(truths)])
    return {"stsim": float(np.mean(st_sim(p, refs))), "spqi": float(np.mean(spqi(p, refs)))}
