"""The safety limiter: the last stage before every actuator; it cannot be disabled.

It enforces :class:`~hapticfx.interfaces.SafetyLimits` on normalised output
(1.0 = the actuator's full range): a hard peak, an RMS ceiling over a sliding
window, and for pulse actuators a maximum on-time and duty cycle. It is
stateful so that streaming actuators can feed it block by block; every
intervention is counted.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .interfaces import SafetyLimits
from .signal import valid_signal


@dataclass(frozen=True)
class LimiterReport:
    """How often each limit acted, and the largest reduction applied."""

    peak_events: int = 0
    rms_events: int = 0
    on_time_events: int = 0
    duty_events: int = 0
    max_reduction_db: float = 0.0
    acted: tuple[str, ...] = ()  # which limits acted: "peak 0.2 set by effect falling_brick.yaml", ...

    @property
    def total(self) -> int:
        return self.peak_events + self.rms_events + self.on_time_events + self.duty_events

    def summary(self) -> str:
        if not self.total:
            return "safety limiter: no limiting"
        parts = [f"{n} {label}" for n, label in (
            (self.peak_events, "peak"), (self.rms_events, "RMS"),
            (self.on_time_events, "on-time"), (self.duty_events, "duty-cycle"),
        ) if n]
        which = f"; {', '.join(self.acted)}" if self.acted else ""
        return f"safety limiter acted: {', '.join(parts)} (max reduction {self.max_reduction_db:.1f} dB{which})"


class _RunStates(Sequence):
    """The limiter's state before each block of a run limited in one pass, made when asked for
    (a queue's run has a hundred blocks, and most of their states are never restored)."""

    def __init__(self, first: tuple, joined: np.ndarray, tail: int, keep: int, at_s: float, block: int,
                 rate_hz: float, events: np.ndarray, reduction: np.ndarray):
        self._first, self._joined, self._tail, self._keep = first, joined, tail, keep
        self._at_s, self._block, self._rate_hz = at_s, block, rate_hz
        self._events, self._reduction = events, reduction

    def __len__(self) -> int:
        return self._events.size - 1

    def __getitem__(self, i: int) -> tuple:
        if not 0 <= i < len(self):
            raise IndexError(i)
        if i == 0:
            return self._first
        end = self._tail + i * self._block
        tail = self._joined[max(0, end - self._keep):end] if self._keep else np.zeros(0)
        counts = {**self._first[3], "peak_events": int(self._events[i])}
        return tail, (), self._at_s + i * self._block / self._rate_hz, counts, float(self._reduction[i]), (0, 0)


class SafetyLimiter:
    """Enforces limits on a stream of normalised samples at ``rate_hz``.

    ``process`` never returns a sample above ``limits.peak`` in magnitude, and
    never lets the RMS over any ``limits.rms_window_s`` window (including
    windows spanning earlier calls) exceed ``limits.rms``; when ``limits`` were
    lowered from an actuator's, its hard limits hold as well, each over its own
    window. For pulse limits, the time above ``on_threshold`` is capped per pulse and
    over any ``duty_window_s`` window (including windows spanning earlier calls). A
    pulse is the time above the threshold until the signal has stayed under it for
    ``pulse_gap_s`` (an oscillation's zero crossings do not end it), across calls.

    ``splice_s``: the RMS limit also holds where the device plays the output with up to this much cut out
    of any window (a sound server that drops part of a stream around an underrun, and joins the rest
    without silence). Each window then takes its energy budget over ``splice_s`` more, so a sustained
    output is limited a little lower: with a 3 ms splice and a 50 ms window, to 97 % of the RMS limit.
    """

    on_threshold = 0.05
    pulse_gap_s = 0.01

    def __init__(self, limits: SafetyLimits, rate_hz: float, *, splice_s: float = 0.0):
        self.limits = limits
        self.rate_hz = float(rate_hz)
        self.splice_s = float(splice_s)
        every = limits.constraints()  # the effect's limits, the actuator's hard ones, and any others on the output
        peak = min(every, key=lambda c: (c.peak, c.hard is not None))
        self._peak, self._peak_by = peak.peak, f"peak {peak.peak:g} set by {peak.source or 'unnamed'}"
        by = {}
        guard = int(np.ceil(self.splice_s * self.rate_hz))
        for c in sorted(every, key=lambda c: c.hard is not None):
            n = max(1, int(round(c.rms_window_s * self.rate_hz)))
            # A window n + guard long holds no more than the energy n may: where the device cuts up to
            # `guard` samples out of a stretch (a sound server splicing around an underrun), the n samples
            # it plays together came from at most n + guard of ours, so they hold no more either.
            by.setdefault((c.rms * float(np.sqrt(n / (n + guard))), n + guard), c)
        self._rms = sorted(by)
        self._rms_by = {k: f"RMS {c.rms:g} over {c.rms_window_s * 1e3:g} ms set by {c.source or 'unnamed'}"
                        for k, c in by.items()}
        self._acted: set[str] = set()
        self._win = max(n for _, n in self._rms)
        on = [c.max_on_s for c in every if c.max_on_s is not None]
        duty = [c.max_duty for c in every if c.max_duty is not None]
        self._max_on_s = min(on) if on else None
        self._max_duty = min(duty) if duty else None
        self._duty_window_s = limits.duty_window_s
        self._tail = np.zeros(0)  # last win-1 output samples, for windows across calls
        self._on_history: deque[tuple[float, float]] = deque()  # (end_s, on_s) per call
        self._pulse = (0, 0)  # on-samples of the last pulse so far, and samples off since its last one
        self._gap_n = max(1, int(round(self.pulse_gap_s * self.rate_hz)))
        self._clock_s = 0.0
        self._lock = threading.Lock()
        self._counts = dict(peak_events=0, rms_events=0, on_time_events=0, duty_events=0)
        self._max_reduction = 1.0

    def _note(self, kind: str, factor: float, by: str | None = None) -> None:
        self._counts[kind] += 1
        if by is not None:
            self._acted.add(by)
        self._max_reduction = min(self._max_reduction, factor)

    def process(self, samples, *, at_s: float | None = None, floor: np.ndarray | None = None) -> np.ndarray:
        """Return ``samples`` (time on the last axis) within the limits.

        ``at_s`` is when the block starts on the caller's clock (seconds); a gap
        since the previous block counts as silence for the RMS and duty windows.
        Without it, blocks are taken as contiguous.

        ``floor`` (1D, as long as the block): what an earlier version of this stretch put there, which the
        device may already have played (audio written over a queue the server reads ahead of). The RMS
        limit then holds whichever of the two versions the device plays, switching from the earlier one to
        this one anywhere: every window is checked against the larger of the two, sample by sample.
        """
        x = valid_signal(samples, name="limiter input").copy()
        with self._lock:
            if at_s is not None and at_s > self._clock_s:
                self._tail = self._tail_after_gap(at_s)
                if self._max_on_s is not None:
                    self._pulse = self._pulse_after(self._pulse, int(round((at_s - self._clock_s) * self.rate_hz)))
                self._clock_s = float(at_s)
            peak = float(max(x.max(), -x.min()))  # no |x| array: a render's 24,000 samples
            if peak > self._peak:
                factor = self._peak / peak
                x *= factor
                self._note("peak_events", factor, self._peak_by)
            x = self._limit_rms(x, floor)
            if self._max_on_s is not None or self._max_duty is not None:
                x = self._limit_pulses(x)
            np.clip(x, -self._peak, self._peak, out=x)  # guarantee against rounding
            self._clock_s += x.shape[-1] / self.rate_hz
            keep = self._win - 1
            flat = np.max(np.abs(x), axis=0) if x.ndim > 1 else x
            if floor is not None:
                flat = np.maximum(np.abs(flat), np.abs(floor))
            if not keep:
                self._tail = np.zeros(0)
            elif flat.size >= keep:  # a copy: the caller owns the output
                self._tail = flat[-keep:].copy()
            else:
                self._tail = np.concatenate([self._tail, flat])[-keep:]
        return x

    def process_blocks(self, samples, *, block: int, at_s: float,
                       floor: np.ndarray | None = None) -> tuple[np.ndarray, Sequence[tuple]]:
        """``process`` over ``samples`` (1D) cut into consecutive blocks of ``block`` samples, the first
        at ``at_s`` (``floor``, if given, cut the same way): the output, and the :meth:`state` before each block.

        The same as calling ``process`` block by block, and in one pass where the RMS limit does not
        act anywhere in the run (the usual case, even where blocks are peak-limited; pulse limits
        always go block by block).
        """
        x = valid_signal(samples, name="limiter input", ndim=1)
        starts = range(0, x.size, block)
        with self._lock:
            if self._max_on_s is None and self._max_duty is None and x.size:
                done = self._blocks_in_one_pass(x, block, starts, at_s, floor)
                if done is not None:
                    return done
        states, out = [], np.empty_like(x)
        for k in starts:
            states.append(self.state())
            out[k:k + block] = self.process(x[k:k + block], at_s=at_s + k / self.rate_hz,
                                            floor=None if floor is None else floor[k:k + block])
        return out, states

    def _blocks_in_one_pass(self, x: np.ndarray, block: int, starts: range, at_s: float, floor):
        """``process_blocks`` without a loop over blocks, or None (nothing changed) where the RMS limit
        would act: each block's peak gain is the one ``process`` would give it, and where no RMS window
        of the peak-limited run is over its budget, no block's own check would find one either."""
        keep = self._win - 1
        peaks = np.maximum.reduceat(np.abs(x), np.asarray(starts))
        acts = peaks > self._peak
        gains = np.ones_like(peaks)
        gains[acts] = self._peak / peaks[acts]
        out = x * np.repeat(gains, block)[:x.size] if acts.any() else x.copy()
        np.clip(out, -self._peak, self._peak, out=out)
        tail = self._tail_after_gap(at_s) if at_s > self._clock_s else self._tail
        joined = np.concatenate([tail, out if floor is None else np.maximum(np.abs(out), np.abs(floor))])
        if self._over_budget((joined * joined,), slack=1 + 1e-12):
            return None
        events = self._counts["peak_events"] + np.concatenate([[0], np.cumsum(acts)])
        reduction = np.minimum.accumulate(np.concatenate([[self._max_reduction], gains]))
        states = _RunStates(self._state(), joined, tail.size, keep, at_s, block, self.rate_hz, events, reduction)
        if events[-1] > self._counts["peak_events"]:
            self._acted.add(self._peak_by)
        self._counts["peak_events"] = int(events[-1])
        self._max_reduction = float(reduction[-1])
        self._tail = joined[-keep:] if keep else np.zeros(0)
        self._clock_s = at_s + x.size / self.rate_hz
        return out, states

    def state(self) -> tuple:
        """Everything ``process`` changes, to :meth:`restore` later and limit the same stretch again
        (audio written ahead of playback and then mixed into: the output goes on exactly from there)."""
        with self._lock:
            return self._state()

    def _state(self) -> tuple:
        # _tail is replaced, never changed in place
        return (self._tail, tuple(self._on_history), self._clock_s, dict(self._counts), self._max_reduction,
                self._pulse)

    def _tail_after_gap(self, at_s: float) -> np.ndarray:
        """The output tail with the silence between the last block and ``at_s`` (seconds, later) added."""
        keep = self._win - 1
        if not keep:
            return self._tail
        gap_n = int((at_s - self._clock_s) * self.rate_hz)
        return np.concatenate([self._tail, np.zeros(min(gap_n, keep))])[-keep:]

    def restore(self, state: tuple) -> None:
        """Go back to a :meth:`state` taken before."""
        with self._lock:
            self._tail, history, self._clock_s, counts, self._max_reduction, self._pulse = state
            self._on_history, self._counts = deque(history), dict(counts)

    def _over_budget(self, pieces: Sequence[np.ndarray], slack: float = 1.0) -> bool:
        """Whether any window of any RMS constraint holds more energy than it may: ``pieces``, consecutive
        stretches of the squared output, are joined only where a window has to be looked at (a render's
        24,000 samples and the tail before them: joining them cost more than the whole check)."""
        # Not a BLAS dot product: OpenBLAS hands a long one to its helper thread, which a busy core can stall
        # for milliseconds.
        total = sum(float(p.sum()) for p in pieces)  # no window holds more than all of it: most impacts stop here
        sq = None
        for rms, win in self._rms:
            budget = rms * rms * win * slack
            if total <= budget:
                continue
            if sq is None:
                sq = pieces[0] if len(pieces) == 1 else np.concatenate(pieces)
            # Cheap bound first: a window touches at most `reach` consecutive blocks of win/8 samples.
            size = max(1, win // 8)
            full = sq.size // size * size
            blocks = np.add.reduceat(sq, np.arange(0, sq.size, size)) if full != sq.size else \
                sq.reshape(-1, size).sum(axis=1)
            reach = -(-win // size) + 1
            csum = np.concatenate([[0.0], np.cumsum(blocks)])
            r = min(reach, blocks.size)
            if float(np.max(csum[r:] - csum[:-r])) <= budget:
                continue
            exact = np.concatenate([[0.0], np.cumsum(sq)])
            n = min(win, sq.size)
            if float(np.max(exact[n:] - exact[:-n])) > budget:
                return True
        return False

    def _limit_rms(self, x: np.ndarray, floor: np.ndarray | None) -> np.ndarray:
        mono = np.max(np.abs(x), axis=0) if x.ndim > 1 else x
        sq = mono * mono
        floor_sq = None if floor is None else np.asarray(floor, dtype=np.float64) ** 2  # either version may play
        if not self._over_budget((self._tail ** 2, sq if floor_sq is None else np.maximum(sq, floor_sq)),
                                 slack=1 + 1e-12):
            return x
        # Energy the earlier (already sent) samples contribute cannot be changed: scale only the new samples
        # so that every window reaching into them stays within budget, for every constraint. Each window
        # ending at new sample j holds a fixed part of the tail and the new samples up to j.
        checks = []
        for rms, win in self._rms:
            tail_sq = self._tail[-(win - 1):] ** 2 if win > 1 and self._tail.size else np.zeros(0)
            csum_tail = np.concatenate([[0.0], np.cumsum(tail_sq)])
            j = np.arange(sq.size)
            from_tail = np.minimum(tail_sq.size, np.maximum(0, win - 1 - j))  # tail samples in window j
            fixed = csum_tail[-1] - csum_tail[tail_sq.size - from_tail]
            first = np.maximum(0, j - win + 1)
            checks.append((rms * rms * win - fixed, first, j + 1, (rms, win)))

        def fits(gains: np.ndarray) -> np.ndarray:
            """Which of ``gains`` keep every window within budget."""
            played = sq[None, :] * (gains * gains)[:, None]
            if floor_sq is not None:
                played = np.maximum(played, floor_sq[None, :])
            c = np.concatenate([np.zeros((gains.size, 1)), np.cumsum(played, axis=1)], axis=1)
            ok = np.ones(gains.size, dtype=bool)
            for budget, first, end, _ in checks:
                ok &= np.max(c[:, end] - c[:, first] - budget, axis=1) <= 0.0
            return ok

        whole = sq if floor_sq is None else np.maximum(sq, floor_sq)
        c1 = np.concatenate([[0.0], np.cumsum(whole)])
        acting = [key for budget, first, end, key in checks if np.max(c1[end] - c1[first] - budget) > 0.0]

        if floor_sq is None:  # each window's energy is gain^2 times its new part's, plus what it holds already
            c1 = np.concatenate([[0.0], np.cumsum(sq)])
            lo = 1.0
            for budget, first, end, _ in checks:
                part = c1[end] - c1[first]
                with np.errstate(over="ignore"):  # a window of denormal energy: its ratio is inf, no constraint
                    ratio = budget[part > 0] / part[part > 0]
                if ratio.size:
                    lo = min(lo, float(np.sqrt(max(0.0, float(ratio.min())))) * (1 - 1e-9))
            self._note("rms_events", max(lo, 1e-12), self._rms_by[acting[0]] if acting else None)
            return x * lo
        # The energy grows with the gain: between a gain that fits (lo) and one that does not (lo + step),
        # try `parts - 1` gains at once and narrow to the part below the first that does not fit (a few
        # array passes where a bisection took thirty; fewer gains a pass for long blocks).
        parts = max(2, min(64, 200_000 // max(1, sq.size)))
        lo, step = 0.0, 1.0
        for _ in range(int(np.ceil(np.log(1e6) / np.log(parts)))):
            grid = lo + step * np.arange(1, parts) / parts
            ok = fits(grid)
            n_ok = ok.size if ok.all() else int(np.argmin(ok))  # fits is monotone: a run of True first
            lo = float(grid[n_ok - 1]) if n_ok else lo
            step /= parts
        self._note("rms_events", max(lo, 1e-12), self._rms_by[acting[0]] if acting else None)
        return x * lo

    def _limit_pulses(self, x: np.ndarray) -> np.ndarray:
        mono = np.max(np.abs(x), axis=0) if x.ndim > 1 else np.abs(x)
        on = mono > self.on_threshold
        n = on.size
        if self._max_on_s is not None and n:
            over = self._past_on_time(on)
            if over.any():
                x = x.copy()
                x[..., over] = 0.0
                on &= ~over
        if self._max_duty is not None:
            # a call's on-time counts until its end leaves the window: every window that holds any part
            # of an earlier call is checked against all of that call's on-time
            now = self._clock_s
            while self._on_history and self._on_history[0][0] <= now - self._duty_window_s:
                self._on_history.popleft()
            used = sum(s for _, s in self._on_history)
            budget = self._max_duty * self._duty_window_s - used
            on_s = float(np.count_nonzero(on)) / self.rate_hz
            if on_s > budget:
                allowed_n = max(0, int(budget * self.rate_hz))
                idx = np.flatnonzero(on)
                x = x.copy()
                if allowed_n < idx.size:
                    x[..., idx[allowed_n]:] = 0.0
                self._note("duty_events", allowed_n / idx.size if idx.size else 0.0)
                on_s = allowed_n / self.rate_hz
            self._on_history.append((now + n / self.rate_hz, on_s))
        return x

    def _pulse_after(self, pulse: tuple[int, int], off_n: int) -> tuple[int, int]:
        """The pulse state after ``off_n`` more samples under the threshold (its count ends at pulse_gap_s)."""
        return pulse[0], min(pulse[1] + off_n, self._gap_n)

    def _past_on_time(self, on: np.ndarray) -> np.ndarray:
        """Where ``on`` (the input above the threshold) is past ``max_on_s`` in its pulse: the input's pulse
        goes on, the output stays silent until it ends. The last pulse is carried into the next call."""
        n, (run, off) = on.size, self._pulse
        idx = np.flatnonzero(on)
        if not idx.size:
            self._pulse = self._pulse_after(self._pulse, n)
            return on
        gaps = np.diff(idx, prepend=idx[0] - off - 1) - 1  # samples off before each on-sample
        starts = gaps >= self._gap_n
        starts[0] |= run == 0
        first = np.maximum.accumulate(np.where(starts, np.arange(idx.size), 0))  # its pulse's first on-sample
        place = np.arange(idx.size) - first + 1 + np.where(first == 0, 0 if starts[0] else run, 0)
        self._pulse = self._pulse_after((int(place[-1]), 0), n - 1 - int(idx[-1]))
        max_n = int(self._max_on_s * self.rate_hz)
        over = np.zeros(n, dtype=bool)
        over[idx[place > max_n]] = True
        if over.any():
            self._note("on_time_events", max_n / int(place.max()))
        return over

    def report(self) -> LimiterReport:
        with self._lock:
            db = -20 * np.log10(self._max_reduction) if self._max_reduction > 0 else float("inf")
            return LimiterReport(**self._counts, max_reduction_db=float(db), acted=tuple(sorted(self._acted)))
