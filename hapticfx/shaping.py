"""Shaping: from a model's profile to an actuator's input.

Gain and scale to the actuator's normalised range, polyphase resampling from
the profile rate to the actuator rate, and a zero-phase band limit to the
actuator's usable band. The safety limiter comes after this, always.
"""

from __future__ import annotations

from fractions import Fraction

from .dsp import resample_poly, zero_phase_butterworth
from .interfaces import ActuatorSpec
from .signal import Signal, valid_number


def resample(signal: Signal, rate_hz: float) -> Signal:
    """``signal`` at ``rate_hz``, by a polyphase filter (exact rational ratio)."""
    rate_hz = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    if rate_hz == signal.rate_hz:
        return signal
    ratio = Fraction(rate_hz / signal.rate_hz).limit_denominator(1000)
    out = resample_poly(signal.samples, ratio.numerator, ratio.denominator)
    return Signal(out, signal.rate_hz * ratio.numerator / ratio.denominator)


def band_limit(signal: Signal, band_hz: tuple[float, float], *, order: int = 2) -> Signal:
    """Zero-phase Butterworth band limit; an edge at 0 or near Nyquist is left open."""
    nyq = signal.rate_hz / 2
    lo = band_hz[0] if 0 < band_hz[0] < nyq else None
    hi = band_hz[1] if 0 < band_hz[1] < 0.95 * nyq else None
    if lo is None and hi is None:
        return signal
    return signal.with_samples(zero_phase_butterworth(signal.samples, signal.rate_hz, low_hz=lo, high_hz=hi,
                                                      order=order))


def shape(profile: Signal, spec: ActuatorSpec, *, gain: float, scale: float) -> Signal:
    """Profile (model units) -> actuator input (normalised, before the safety limiter).

    ``scale`` converts model units to the actuator's full range (for a profile in g,
    ``1 / full_scale_g``); ``gain`` is the effect's gain.
    """
    out = profile.with_samples(profile.samples * (gain * scale))
    out = resample(out, spec.rate_hz)
    if spec.waveform:
        out = band_limit(out, spec.band_hz)
    return out
