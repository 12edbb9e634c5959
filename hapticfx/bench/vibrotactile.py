"""Perceptual vibrotactile quality, ST-SIM and SPQI, through the ``vibromaf`` package (Hofbauer et al., MIT).

Checked on known cases (tests/test_formats_bench.py): a signal against itself scores 1 on
both. Two behaviours of vibromaf 0.0.8 to know: it assumes signals sampled at 2.8 kHz (the
codec literature's rate), so both signals are resampled to :data:`RATE_HZ` first; and its
ST-SIM raises a negative number to a fractional power for some pairs (noise shifted by 1 to
20 samples, say), which returns a complex number: such a score is reported as NaN, not as its
real part. It works on blocks of 512 samples (183 ms), refuses shorter signals and drops a
last partial block: both signals are padded with silence to whole blocks. ST-SIM is not bounded by 1 either (a signal at half its level scored 1.013) and
both measures drop steeply for small delays (a decaying 120 Hz sine shifted by 5 samples:
ST-SIM 0.37, SPQI 0.01), so a round trip that moves the carrier's phase scores low on them
even where its envelope and spectrum hold.
"""

from __future__ import annotations

import numpy as np

from ..dsp import resample_rate

RATE_HZ = 2800.0
BLOCK = 512  # vibromaf's block length: it refuses shorter signals and drops a last partial block


def available() -> bool:
    try:
        import vibromaf  # noqa: F401
    except ImportError:
        return False
    return True


def _real(score) -> float:
    value = complex(score)
    return float(value.real) if value.imag == 0 and np.isfinite(value.real) else float("nan")


def scores(reference: np.ndarray, distorted: np.ndarray, rate_hz: float) -> tuple[float, float]:
    """``(ST-SIM, SPQI)`` of ``distorted`` against ``reference`` (equal lengths, at ``rate_hz``); NaN where undefined."""
    import warnings

    from vibromaf.metrics.spqi import spqi
    from vibromaf.metrics.stsim import st_sim

    ref = resample_rate(np.asarray(reference, dtype=float), rate_hz, RATE_HZ)
    dis = resample_rate(np.asarray(distorted, dtype=float), rate_hz, RATE_HZ)
    pad = lambda x: np.pad(x, (0, -len(x) % BLOCK + (BLOCK if len(x) == 0 else 0)))  # noqa: E731
    ref, dis = pad(ref), pad(dis)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # log10 of empty bands in silence
        return _real(st_sim(dis, ref)), _real(spqi(dis, ref))
