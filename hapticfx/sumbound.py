"""The host's limit on the sum of overlapping impacts, for an actuator that sums them itself but whose own
limiter the host does not trust (it declares ``limits_mix`` and failed, or never took, the conformance check).

The host cannot see the sum such an actuator makes, nor exactly when it starts each impact. So it bounds the
sum whatever their alignment: the peak of a sum is at most the sum of the peaks, and the RMS of a sum over
any window at most the sum of each one's largest windowed RMS (Minkowski). Each new impact is scaled so that,
with every impact that may sound with it, both sums stay within the limits. An impact is taken to sound from
when it is placed (``play()``, or the time a ``takes_time`` actuator is given) for its length, give or take
``slack_s`` (a mixer's buffer), and to share windows with what sounds less than a window before or after it:
times may come out of order (a sender's ``at``), so each is checked against every impact kept near it. Impacts
are kept for :data:`HORIZON_S` behind the latest; one placed earlier than that cannot be bounded and is
silenced (counted in the report).
"""

from __future__ import annotations

import bisect
import threading

import numpy as np

from .conformance import limits_own_mix, window_rms
from .interfaces import Actuator, SafetyLimits
from .safety import LimiterReport, SafetyLimiter

SLACK_S = 0.25
HORIZON_S = 2.0  # how far behind the latest impact one may be placed and still be bounded


class SumBound:
    """Scales impacts so that any sum of those that may overlap stays within ``limits`` (see module doc)."""

    def __init__(self, limits: SafetyLimits, rate_hz: float, *, slack_s: float = SLACK_S):
        every = limits.constraints()
        self.limits, self.rate_hz, self.slack_s = limits, float(rate_hz), slack_s
        self._peak = min(c.peak for c in every)
        self._rms = sorted({(c.rms, max(1, int(round(c.rms_window_s * self.rate_hz)))) for c in every})
        self._reach_s = max(w for _, w in self._rms) / self.rate_hz + slack_s
        self._sounding: list[tuple[float, float, float, tuple[float, ...]]] = []  # (end, start, peak, rms), by end
        self._latest = -np.inf  # the latest end placed
        self._lock = threading.Lock()
        self._events = 0
        self._least = 1.0
        self._silenced = 0

    def process(self, samples: np.ndarray, *, at_s: float) -> np.ndarray:
        """``samples`` (1D) that sound from ``at_s`` (seconds on the output's clock), scaled so that the bounds
        hold."""
        x = np.asarray(samples, dtype=np.float64)
        peak = float(np.max(np.abs(x))) if x.size else 0.0
        rms = tuple(float(window_rms(x, win).max()) if x.size else 0.0 for _, win in self._rms)
        start, end = float(at_s), float(at_s) + x.size / self.rate_hz
        with self._lock:
            if start - self._reach_s < self._latest - HORIZON_S:  # what sounded with it may be forgotten
                self._silenced += 1
                self._events += 1
                self._least = 0.0
                return np.zeros_like(x)
            near = [(p, r) for e, s, p, r in self._sounding if e + self._reach_s >= start and s - self._reach_s <= end]
            gain = 1.0
            used_peak = sum(p for p, _ in near)
            if peak > 0:
                gain = min(gain, max(0.0, self._peak - used_peak) / peak)
            for k, (limit, _) in enumerate(self._rms):
                used = sum(r[k] for _, r in near)
                if rms[k] > 0:
                    gain = min(gain, max(0.0, limit - used) / rms[k])
            if gain < 1.0:
                self._events += 1
                self._least = min(self._least, gain)
            self._latest = max(self._latest, end)
            bisect.insort(self._sounding, (end, start, peak * gain, tuple(r * gain for r in rms)))
            del self._sounding[:bisect.bisect_left(self._sounding, (self._latest - HORIZON_S,))]
        return x * gain

    def report(self) -> LimiterReport:
        with self._lock:
            db = -20 * np.log10(self._least) if self._least > 0 else float("inf")
            acted = ("sum of overlapping impacts (host bound)",) if self._events else ()
            if self._silenced:
                acted += (f"{self._silenced} impacts placed over {HORIZON_S:g} s before the latest (host bound: "
                          "silenced)",)
            return LimiterReport(peak_events=self._events, max_reduction_db=float(db), acted=acted)


def host_limiter(actuator: Actuator, limits, *, summed: bool) -> SafetyLimiter | SumBound | None:
    """The host's limit on what reaches one opened actuator, at the rate it reports after ``open()``: none
    where the actuator limits its own mix and its limiter passed the conformance check
    (:mod:`hapticfx.conformance`), a bound on any sum where it sums impacts without that
    (:class:`~hapticfx.sumbound.SumBound`), a limiter on the stream where several effects (or sites) share it
    (``summed``; a single effect's pipeline limits its stream itself)."""
    rate = actuator.spec.rate_hz
    if limits_own_mix(actuator):
        return None
    if actuator.limits_mix:
        return SumBound(limits, rate)
    return SafetyLimiter(limits, rate) if summed else None
