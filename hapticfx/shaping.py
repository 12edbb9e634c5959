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

import threading
from collections import OrderedDict

from .dsp import causal_butterworth, rate_ratio, resample_rate, taper
from .interfaces import ActuatorSpec, Term, Terms, weighted_sum
from .signal import Signal, valid_number

FADE_IN_S = 0.002   # shorter than any onset a model puts after its first sample
FADE_OUT_S = 0.010
RATE_PPM = 100.0  # a resampled rate this close to the actuator's is the actuator's (crystals: 20-100 ppm)


def resample(signal: Signal, rate_hz: float) -> Signal:
    """``signal`` at ``rate_hz``, by a polyphase filter (a rational ratio, :func:`~hapticfx.dsp.rate_ratio`).

    Where the ratio's rate is within ``RATE_PPM`` of ``rate_hz`` (a profile at 1001 Hz to 48 kHz comes out
    at 47999.9988 Hz), the result is ``rate_hz``'s: an error below a sound card's own clock's, which a WAV
    file and an actuator's rate check would otherwise refuse.
    """
    rate_hz = valid_number(rate_hz, name="rate_hz", minimum=1e-9)
    if rate_hz == signal.rate_hz:
        return signal
    rate = float(signal.rate_hz * rate_ratio(signal.rate_hz, rate_hz))
    rate = rate_hz if abs(rate - rate_hz) <= RATE_PPM * 1e-6 * rate_hz else rate
    return Signal.adopt(resample_rate(signal.samples, signal.rate_hz, rate_hz), rate)


def _band_edges(rate_hz: float, band_hz: tuple[float, float]) -> tuple[float | None, float | None]:
    """The band's edges that a filter at ``rate_hz`` applies; one at 0 or near Nyquist is left open (None)."""
    nyq = rate_hz / 2
    return (band_hz[0] if 0 < band_hz[0] < nyq else None,
            band_hz[1] if 0 < band_hz[1] < 0.95 * nyq else None)


def shape(profile: Signal, spec: ActuatorSpec, *, gain: float, scale: float) -> Signal:
    """Profile (model units) -> actuator input (normalised, before the safety limiter).

    ``scale`` converts model units to the actuator's full range (for a profile in g,
    ``1 / full_scale_g``); ``gain`` is the effect's gain.
    """
    rate = profile.rate_hz
    x = profile.samples * (gain * scale)  # a per-impact path: arrays between the steps, one Signal at the end
    if spec.waveform:  # a pulse actuator (a solenoid) reads the envelope's width: no band, no fades
        lo, hi = _band_edges(rate, spec.band_hz)
        if lo is not None or hi is not None:
            x = causal_butterworth(x, rate, low_hz=lo, high_hz=hi)
        x = taper(x, rate, fade_in_s=FADE_IN_S, fade_out_s=FADE_OUT_S)
    return resample(Signal.adopt(x, rate), spec.rate_hz)


ATOM_CACHE_BYTES = 64 << 20  # shaped atoms kept per pipeline; the least recently used go first


class ShapedAtoms:
    """Shapes a profile given as :class:`~hapticfx.interfaces.Terms` by summing shaped atoms.

    Every step of :func:`shape` is linear (a gain, a causal filter from rest, fixed
    fades over a fixed length, a polyphase resampler), so the shaped sum of atoms is
    the sum of the shaped atoms. Each atom is shaped once per actuator spec and kept
    under its key (up to :data:`ATOM_CACHE_BYTES`); an impact then costs a weighted
    sum at the actuator's rate. Thread-safe.
    """

    def __init__(self, *, gain: float, scale: float, max_bytes: int = ATOM_CACHE_BYTES):
        self.gain = gain
        self.scale = scale
        self.max_bytes = max_bytes
        self._spec: ActuatorSpec | None = None
        self._atoms: OrderedDict = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()

    def _atom(self, term: Term, rate_hz: float, spec: ActuatorSpec) -> Signal:
        with self._lock:
            if spec != self._spec:  # the actuator agreed on another rate when it opened
                self._atoms.clear()
                self._bytes = 0
                self._spec = spec
            found = self._atoms.get(term.key)
            if found is not None:
                self._atoms.move_to_end(term.key)
                return found
        shaped = shape(Signal(term.samples, rate_hz), spec, gain=self.gain, scale=self.scale)
        with self._lock:
            if spec == self._spec and term.key not in self._atoms:
                self._atoms[term.key] = shaped
                self._bytes += shaped.samples.nbytes
                while self._bytes > self.max_bytes and len(self._atoms) > 1:
                    self._bytes -= self._atoms.popitem(last=False)[1].samples.nbytes
        return shaped

    def warm(self, atoms: Terms, spec: ActuatorSpec) -> None:
        """Shape every atom of ``atoms`` now, ahead of the impacts that will use them."""
        for term in atoms.items:
            self._atom(term, atoms.rate_hz, spec)

    def shape(self, terms: Terms, spec: ActuatorSpec) -> Signal:
        """``shape(terms.profile(), spec, ...)``, from the shaped atoms."""
        shaped = [self._atom(term, terms.rate_hz, spec) for term in terms.items]
        samples = weighted_sum((t.weight, a.samples) for t, a in zip(terms.items, shaped))
        return Signal.adopt(samples, shaped[0].rate_hz)
