"""Time registration of two profiles and the morph between them (dynamic time warping).

A profile's events move with velocity: an object that bounces on the helmet comes
back later when it fell faster, so the same bounce sits a few milliseconds apart
in the two neighbours' profiles. A sample-by-sample blend of the two then shows two
half-height bounces instead of one bounce halfway. :func:`warp_path` pairs the
samples of ``a`` with those of ``b`` (monotone, within ``band`` samples of the
diagonal; each step off the diagonal costs ``penalty``, in units of the squared
peak, so that noise does not warp); :func:`morph` moves both time and value a
fraction ``w`` of the way along the pairs and reads the result back on the sample
grid. ``w`` = 0 gives ``a``, ``w`` = 1 gives ``b``; with no step off the diagonal
the morph is the plain blend ``(1 - w) a + w b``.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import resample

BAND = 32  # samples: 32 ms at 1 kHz, more than a bounce moves between two recorded velocities


def warp_path(a: np.ndarray, b: np.ndarray, *, penalty: float, band: int = BAND) -> np.ndarray:
    """Pairs ``(i, j)`` ``(K, 2)`` of the cheapest monotone alignment of ``a`` and ``b`` (equal lengths; cost
    ``sum (a_i - b_j)^2`` of the peak-normalised signals plus ``penalty`` per step off the diagonal, within
    ``band`` samples of it).

    Row by row: entering row ``i`` at column ``k`` (from ``(i-1, k-1)`` or ``(i-1, k)``) costs ``F[k]``, and
    moving right along the row from ``k`` to ``j`` adds the row's costs in between and ``penalty`` per step,
    so ``total[i, j] = C[j] + penalty j + min_{k <= j} (F[k] - C[k] - penalty k)`` with ``C`` the row's
    cumulative cost: a running minimum, no loop over columns.
    """
    n = len(a)
    peak = max(float(np.max(np.abs(a))), float(np.max(np.abs(b))), 1e-12)
    x, y = np.asarray(a, dtype=np.float64) / peak, np.asarray(b, dtype=np.float64) / peak
    ramp = penalty * np.arange(n)  # penalty j at column j
    move = np.zeros((n, n), dtype=np.int8)  # 0 diagonal, 1 from (i-1, j), 2 from (i, j-1)
    above = np.full(n + 1, np.inf)  # the row above; entry j + 1 holds column j, entry 0 is before the grid
    above[0] = 0.0  # the start (0, 0) is entered diagonally from outside
    for i in range(n):
        lo, hi = max(0, i - band), min(n, i + band + 1)
        cost = (x[i] - y[lo:hi]) ** 2
        diag, up = above[lo:hi], above[lo + 1:hi + 1] + penalty
        f = cost + np.minimum(diag, up)
        c = np.cumsum(cost)
        row = c + ramp[lo:hi] + np.minimum.accumulate(f - c - ramp[lo:hi])
        left = row + 1e-12 * (1.0 + np.abs(row)) < f  # reached along the row, not entering here (rounding aside)
        left[0] = False
        move[i, lo:hi] = np.where(left, 2, up < diag)
        # this row becomes the one above: the band only moves right, so past hi nothing was ever written
        above[lo] = np.inf
        above[lo + 1:hi + 1] = row
    path = []
    i = j = n - 1
    while True:
        path.append((i, j))
        if i == 0 and j == 0:
            break
        step = move[i, j]
        i, j = (i - 1, j - 1) if step == 0 else (i - 1, j) if step == 1 else (i, j - 1)
    return np.array(path[::-1], dtype=np.int64)


SMOOTH = 3.0  # samples: the Gaussian that turns the path's staircase into a smooth displacement


def displacement(path: np.ndarray, n: int, *, smooth: float = SMOOTH) -> np.ndarray:
    """``d`` ``(n,)``: sample ``i`` of ``a`` pairs with instant ``i + d[i]`` of ``b`` (the mean of its pairs on
    ``path``), smoothed by a Gaussian of ``smooth`` samples."""
    d = np.bincount(path[:, 0], path[:, 1] - path[:, 0], minlength=n) / np.bincount(path[:, 0], minlength=n)
    f = np.fft.rfftfreq(n)
    return np.fft.irfft(np.fft.rfft(d) * np.exp(-0.5 * (2 * np.pi * f * smooth) ** 2), n=n)


UPSAMPLE = 4  # band-limited (FFT) upsampling before the cubic spline that reads a signal between samples


def _between(x: np.ndarray) -> CubicSpline:
    """``x`` readable at any real instant: FFT-upsampled by :data:`UPSAMPLE` (even extension: no step where the
    period wraps), then a cubic spline, so that what is read moves smoothly with the instant."""
    n = len(x)
    fine = resample(np.concatenate([x, x[::-1]]), 2 * n * UPSAMPLE)[: n * UPSAMPLE]
    return CubicSpline(np.arange(n * UPSAMPLE) / UPSAMPLE, fine)


class Morph:
    """The morph of ``a`` into ``b`` along the displacement ``d`` (:func:`displacement`): at relative position
    ``w`` and instant ``t`` it is ``(1 - w) a(s) + w b(s + d(s))`` with ``s + w d(s) = t``, read between samples
    by :func:`_between` so that it is smooth in ``w``. ``w`` = 0 is ``a``; with ``d`` = 0 it is the plain blend
    ``(1 - w) a + w b``.

    ``s + w d(s)`` never decreases (a warp path is monotone, so ``d' >= -1``, and smoothing keeps that): ``s`` is
    read off it on the upsampled grid, then polished by Newton steps (each at most one fine step), which keeps
    ``s`` smooth in ``w`` where linear interpolation alone would leave kinks.
    """

    def __init__(self, a: np.ndarray, b: np.ndarray, d: np.ndarray):
        self.a, self.b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        self.warped = bool(np.any(np.abs(d) > 1e-9))
        if self.warped:
            self._a, self._b, self._d = _between(self.a), _between(self.b), _between(d)
            self._fine = self._d.x
            self._dd = self._d.derivative()

    def __call__(self, w: float, *, newton: int = 3) -> np.ndarray:
        if not self.warped or w == 0.0:
            return (1.0 - w) * self.a + w * self.b
        t = np.arange(len(self.a), dtype=np.float64)
        s = np.interp(t, self._fine + w * self._d(self._fine), self._fine)
        for _ in range(newton):
            step = (s + w * self._d(s) - t) / np.maximum(1.0 + w * self._dd(s), 1e-6)
            s = s - np.clip(step, -1.0 / UPSAMPLE, 1.0 / UPSAMPLE)
        return (1.0 - w) * self._a(s) + w * self._b(s + self._d(s))


__all__ = ["warp_path", "displacement", "Morph", "BAND", "SMOOTH", "UPSAMPLE"]
