"""Shaping: from a model's profile to an actuator's input.

Gain and scale to the actuator's normalised range; the actuator's band, applied
at the profile's own rate with a causal Butterworth (a profile at 1 kHz holds
nothing above 500 Hz, so that is where the work is small); short raised-cosine
fades, so every output starts and ends at zero (no click at onset, none where a
profile stops); then polyphase resampling to the actuator's rate. An actuator
that plays pulses, not waveforms (``spec.waveform`` false, a solenoid), gets the
profile unfiltered and unfaded: it reads the width of its envelope. The safety
limiter comes after this, always.
"""

from __future__ import annotations

from .dsp import causal_butterworth, rate_ratio, resample_rate, taper
from .interfaces import ActuatorSpec
from .signal import Signal, valid_number

FADE_IN_S = 0.002   # shorter than any onset a model puts after its first sample
FADE_OUT_S = 0.010


def resample(signal: Signal, rate_hz: float) -> Signal:
    """``signal`` at ``rate_hz``, by a polyphase filter (exact rational ratio)."""
    rate_hz = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    if rate_hz == signal.rate_hz:
        return signal
    rate = signal.rate_hz * rate_ratio(signal.rate_hz, rate_hz)
    return Signal(resample_rate(signal.samples, signal.rate_hz, rate_hz), float(rate))


def band_limit(signal: Signal, band_hz: tuple[float, float]) -> Signal:
    """Causal 2nd-order Butterworth band limit; an edge at 0 or near Nyquist is left open."""
    nyq = signal.rate_hz / 2
    lo = band_hz[0] if 0 < band_hz[0] < nyq else None
    hi = band_hz[1] if 0 < band_hz[1] < 0.95 * nyq else None
    if lo is None and hi is None:
        return signal
    return signal.with_samples(causal_butterworth(signal.samples, signal.rate_hz, low_hz=lo, high_hz=hi))


def shape(profile: Signal, spec: ActuatorSpec, *, gain: float, scale: float) -> Signal:
    """Profile (model units) -> actuator input (normalised, before the safety limiter).

    ``scale`` converts model units to the actuator's full range (for a profile in g,
    ``1 / full_scale_g``); ``gain`` is the effect's gain.
    """
    out = profile.with_samples(profile.samples * (gain * scale))
    if spec.waveform:  # a pulse actuator (a solenoid) reads the envelope's width: no band, no fades
        out = band_limit(out, spec.band_hz)
        out = out.with_samples(taper(out.samples, out.rate_hz, fade_in_s=FADE_IN_S, fade_out_s=FADE_OUT_S))
    return resample(out, spec.rate_hz)
