"""From a rendered impact to a parametric description: envelope, breakpoints, frequency curve, onset transient.

1. **Amplitude envelope**: the magnitude of the analytic signal (Hilbert transform), low-passed
   at :data:`ENVELOPE_HZ` forwards and backwards (no delay), sampled every millisecond
   (:data:`GRID_HZ`). For a sine of amplitude A it is A, so the envelope is in the file's own
   unit: a fraction of the actuator's full range.
2. **Breakpoints**: the 1 ms envelope reduced by Ramer-Douglas-Peucker on the vertical
   distance: a breakpoint is added where the straight line between two kept ones strays more
   than ``tolerance`` from the envelope. **Bound**: every 1 ms sample of the envelope lies within
   ``tolerance`` (default 0.01 of full scale) of the piecewise-linear breakpoints.
3. **Frequency curve**: the signal at :data:`WORK_HZ`, Hann frames of :data:`FRAME_S` every
   :data:`HOP_S`; per frame the peak of the zero-padded magnitude spectrum between 10 and 500 Hz
   (parabolic interpolation between bins). Frames quieter than 5% of the envelope's peak take
   their nearest loud neighbour's value. Mapped to 0-1 by the device's range (clamped), median
   filtered over 5 frames, reduced like the envelope with ``frequency_tolerance``.
4. **Transient at the onset**: the onset is the first millisecond at 10% of the envelope's peak;
   when the peak follows within :data:`SHARP_RISE_S` (and ``transients`` is on) the peak becomes
   an emphasis point. Its frequency is the curve's value there; the device plays it as a burst of
   a fixed length (Quest: 36.4 ms at 0 to 12.1 ms at 1), so the burst carries the envelope over
   that window: its amplitude is the envelope's mean over the window and the continuous envelope
   is 0 under it (so the emphasis is never below the envelope at its point, as the spec requires).
"""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

from ..dsp import resample_rate
from .device import Device
from .pattern import Emphasis, Pattern

GRID_HZ = 1000.0
ENVELOPE_HZ = 50.0
WORK_HZ = 2000.0
FRAME_S = 0.080
HOP_S = 0.005
QUIET = 0.05
SHARP_RISE_S = 0.020  # the 50 Hz envelope filter alone takes 13 ms from 10% to the peak of a step
ONSET = 0.10
SEARCH_HZ = (10.0, 500.0)


def envelope(x: np.ndarray, rate_hz: float) -> np.ndarray:
    """The amplitude envelope of ``x`` sampled at :data:`GRID_HZ` (one value per millisecond, from t = 0)."""
    x = np.asarray(x, dtype=np.float64)
    mag = np.abs(sps.hilbert(x))
    cutoff = min(ENVELOPE_HZ, 0.45 * rate_hz)
    if len(mag) > 15:
        sos = sps.butter(2, cutoff, fs=rate_hz, output="sos")
        mag = sps.sosfiltfilt(sos, mag, padlen=min(len(mag) - 1, 3 * 6))
    t = np.arange(int(np.floor((len(x) - 1) / rate_hz * GRID_HZ)) + 1) / GRID_HZ
    return np.clip(np.interp(t, np.arange(len(x)) / rate_hz, mag), 0.0, None)


def reduce_breakpoints(y: np.ndarray, tolerance: float, keep=()) -> np.ndarray:
    """Indices of ``y`` to keep so that linear interpolation between them stays within ``tolerance`` of ``y``."""
    n = len(y)
    kept = sorted({0, n - 1, *[int(k) for k in keep if 0 <= k < n]})
    out = set(kept)
    stack = list(zip(kept[:-1], kept[1:]))
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        k = np.arange(i + 1, j)
        line = y[i] + (y[j] - y[i]) * (k - i) / (j - i)
        dev = np.abs(y[k] - line)
        m = int(np.argmax(dev))
        if dev[m] > tolerance:
            s = int(k[m])
            out.add(s)
            stack += [(i, s), (s, j)]
    return np.array(sorted(out))


def frequency_track(x: np.ndarray, rate_hz: float, env: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(times_s, hz)``: the spectral peak of each frame (quiet frames hold a loud neighbour's value)."""
    work = min(WORK_HZ, rate_hz)
    xw = resample_rate(np.asarray(x, dtype=np.float64), rate_hz, work) if work != rate_hz else np.asarray(x, float)
    frame = max(8, int(round(FRAME_S * work)))
    hop = max(1, int(round(HOP_S * work)))
    nfft = 1 << int(np.ceil(np.log2(max(2048, 4 * frame))))  # about 1 Hz bins at 2 kHz, refined by a parabola
    padded = np.concatenate((np.zeros(frame // 2), xw, np.zeros(frame // 2)))
    centres = np.arange(0, len(xw), hop)
    window = np.hanning(frame)
    freqs = np.fft.rfftfreq(nfft, 1 / work)
    lo, hi = np.searchsorted(freqs, SEARCH_HZ[0]), np.searchsorted(freqs, min(SEARCH_HZ[1], 0.5 * work))
    frames = np.lib.stride_tricks.sliding_window_view(padded, frame)[centres]
    hz = np.empty(len(centres))
    for start in range(0, len(centres), 512):  # blocks of frames: bounded memory on long files
        spec = np.abs(np.fft.rfft(frames[start:start + 512] * window, nfft, axis=1))[:, lo:hi]
        k = np.argmax(spec, axis=1)
        a, b, c = (spec[np.arange(len(k)), np.clip(k + d, 0, spec.shape[1] - 1)] for d in (-1, 0, 1))
        denom = a - 2 * b + c
        shift = np.where((k > 0) & (k < spec.shape[1] - 1) & (denom != 0),
                         0.5 * (a - c) / np.where(denom == 0, 1, denom), 0)
        hz[start:start + 512] = freqs[lo + k] + shift * (freqs[1] - freqs[0])
    times = centres / work
    loud = np.interp(times, np.arange(len(env)) / GRID_HZ, env) >= QUIET * max(float(env.max()), 1e-12)
    if not loud.any():
        return times, np.full(len(times), np.nan)
    idx = np.flatnonzero(loud)
    nearest = idx[np.clip(np.searchsorted(idx, np.arange(len(times))), 0, len(idx) - 1)]
    before = idx[np.clip(np.searchsorted(idx, np.arange(len(times))) - 1, 0, len(idx) - 1)]
    pick = np.where(np.abs(before - np.arange(len(times))) < np.abs(nearest - np.arange(len(times))), before, nearest)
    return times, hz[pick]


def analyse(x: np.ndarray, rate_hz: float, device: Device, *, tolerance: float = 0.01,
            frequency_tolerance: float = 0.02, transients: bool = True) -> Pattern:
    """The parametric description of ``x`` (a fraction of full scale at ``rate_hz``) for ``device``."""
    env = np.clip(envelope(x, rate_hz), 0.0, 1.0)
    if len(env) < 2:
        env = np.array([env[0] if len(env) else 0.0, 0.0])
    peak = int(np.argmax(env))
    emphasis = []
    keep = []
    times, hz = frequency_track(x, rate_hz, env)
    duration = (len(env) - 1) / GRID_HZ
    norm = device.normalised(hz) if np.isfinite(hz).all() else np.full(len(times), 0.5)
    norm = sps.medfilt(norm, 5) if len(norm) >= 5 else norm
    inside = times <= duration
    ftimes, fvals = times[inside], norm[inside]
    if transients and env[peak] > 0:
        onset = int(np.argmax(env >= ONSET * env[peak]))
        if (peak - onset) / GRID_HZ <= SHARP_RISE_S:
            s = float(np.interp(peak / GRID_HZ, ftimes, fvals)) if len(ftimes) else 0.5
            end = min(len(env) - 1, peak + max(1, int(round(device.burst_ms(s) * GRID_HZ / 1000))))
            emphasis.append(Emphasis(peak / GRID_HZ, float(env[peak:end].mean()), s))
            env = env.copy()
            env[peak:end] = 0.0
            keep += [peak, end - 1, end]
    idx = reduce_breakpoints(env, tolerance, keep)
    amplitude = np.column_stack((idx / GRID_HZ, env[idx]))
    if len(ftimes) >= 2:
        fidx = reduce_breakpoints(fvals, frequency_tolerance)
        frequency = np.column_stack((ftimes[fidx], fvals[fidx]))
    else:
        frequency = np.zeros((0, 2))
    return Pattern(amplitude, frequency, tuple(emphasis), peak=float(np.max(np.abs(x), initial=0.0)))
