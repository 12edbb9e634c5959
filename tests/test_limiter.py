"""The safety limiter: for any signal and gain, output stays within the limits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hapticfx.interfaces import SafetyLimits
from hapticfx.safety import SafetyLimiter

RATE = 1000.0
finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


def windowed_rms(x, n):
    sq = np.concatenate([[0.0], np.cumsum(np.asarray(x, np.float64) ** 2)])
    n = min(n, len(x))
    return np.sqrt((sq[n:] - sq[:-n]) / n)


@settings(max_examples=150, deadline=None)
@given(arrays(np.float64, st.integers(1, 400), elements=finite), st.floats(0, 100),
       st.floats(0.05, 1.0), st.floats(0.05, 1.0))
def test_peak_and_rms_never_exceeded(x, gain, peak, rms):
    limits = SafetyLimits(peak=peak, rms=rms, rms_window_s=0.02)
    out = SafetyLimiter(limits, RATE).process(x * gain)
    assert np.all(np.isfinite(out))
    assert np.max(np.abs(out)) <= peak + 1e-12
    win = int(limits.rms_window_s * RATE)
    if len(out) >= win:
        assert np.max(windowed_rms(out, win)) <= rms * (1 + 1e-9)


@settings(max_examples=60, deadline=None)
@given(st.lists(arrays(np.float64, st.integers(1, 60), elements=st.floats(-5, 5)), min_size=2, max_size=8))
def test_rms_holds_across_block_boundaries(blocks):
    limits = SafetyLimits(peak=1.0, rms=0.3, rms_window_s=0.02)
    lim = SafetyLimiter(limits, RATE)
    out = np.concatenate([lim.process(b) for b in blocks])
    win = int(limits.rms_window_s * RATE)
    if len(out) >= win:
        assert np.max(windowed_rms(out, win)) <= 0.3 * (1 + 1e-9)


def test_events_are_counted():
    lim = SafetyLimiter(SafetyLimits(peak=0.5, rms=1.0), RATE)
    lim.process(np.array([0.1, 0.2]))
    assert lim.report().total == 0
    lim.process(np.array([0.0, 2.0, -1.0]))
    rep = lim.report()
    assert rep.peak_events == 1 and rep.max_reduction_db == pytest.approx(12.0412, abs=1e-3)
    assert "1 peak" in rep.summary()


def test_silence_passes_untouched():
    lim = SafetyLimiter(SafetyLimits(), RATE)
    assert np.array_equal(lim.process(np.zeros(100)), np.zeros(100))
    assert lim.report().total == 0


def test_pulse_on_time_and_duty():
    limits = SafetyLimits(max_on_s=0.05, max_duty=0.1, duty_window_s=1.0)
    lim = SafetyLimiter(limits, RATE)
    out = lim.process(np.full(200, 0.5))  # 200 ms pulse, 50 ms allowed
    assert np.count_nonzero(out > lim.on_threshold) == 50
    assert lim.report().on_time_events == 1
    out2 = lim.process(np.full(100, 0.5), at_s=0.3)  # 50 ms more would exceed 100 ms per 1 s
    assert np.count_nonzero(out2 > lim.on_threshold) == 50
    out3 = lim.process(np.full(100, 0.5), at_s=0.5)
    assert np.count_nonzero(out3 > lim.on_threshold) == 0
    rep = lim.report()
    assert (rep.on_time_events, rep.duty_events) == (3, 1)  # calls 1-3 exceed 50 ms; only call 3 exceeds the duty budget
    out4 = lim.process(np.full(40, 0.5), at_s=2.0)  # window passed: budget back
    assert np.count_nonzero(out4 > lim.on_threshold) == 40


def test_a_pulse_is_capped_across_calls_and_each_pulse_on_its_own():
    """A solenoid's pulse split over two blocks (the file outputs feed 512 frames at a time) is one pulse;
    two pulses in one block each get the whole cap; a pulse ends after pulse_gap_s under the threshold,
    in the signal or between calls, and not at an oscillation's zero crossings."""
    limits = SafetyLimits(peak=1, rms=1, max_on_s=0.1)
    lim = SafetyLimiter(limits, RATE)
    a = lim.process(np.r_[np.zeros(10), np.ones(90)], at_s=0.0)
    b = lim.process(np.r_[np.ones(90), np.zeros(10)], at_s=0.1)
    assert np.count_nonzero(np.r_[a, b] > lim.on_threshold) == 100
    assert lim.report().on_time_events == 1
    two = lim.process(np.r_[np.ones(60), np.zeros(10), np.ones(60)], at_s=0.2)  # 10 ms off: pulse_gap_s
    assert np.count_nonzero(two > lim.on_threshold) == 120
    lim.process(np.ones(80), at_s=0.4)
    after_gap = lim.process(np.ones(80), at_s=0.49)  # 10 ms of silence between calls: a new pulse
    assert np.count_nonzero(after_gap > lim.on_threshold) == 80
    lim.process(np.zeros(20), at_s=0.6)
    buzz = lim.process(np.sin(2 * np.pi * 150 * np.arange(500) / RATE), at_s=0.62)  # its zero crossings
    assert np.count_nonzero(np.abs(buzz) > lim.on_threshold) <= 100  # do not end its pulse


@pytest.mark.parametrize("seed", range(4))
def test_no_window_holds_more_on_time_than_the_duty_allows(seed):
    """Every duty window, wherever it starts, against what came out of blocks of random length and gaps."""
    limits = SafetyLimits(peak=1, rms=1, max_on_s=0.1, max_duty=0.25, duty_window_s=1.0)
    lim = SafetyLimiter(limits, RATE)
    rng = np.random.default_rng(seed)
    timeline = np.zeros(int(12 * RATE))
    t = 0
    while t < timeline.size - 1500:  # blocks shorter and longer than the window, their pulses anywhere
        x = np.concatenate([np.zeros(int(rng.integers(0, 300))), np.ones(int(rng.integers(1, 150))),
                            np.zeros(int(rng.integers(0, 2)) * int(rng.integers(0, 1200)))])
        timeline[t:t + x.size] = lim.process(x, at_s=t / RATE)
        t += x.size + int(rng.integers(0, 3)) * int(rng.integers(0, 50))
    on = np.concatenate([[0], np.cumsum(timeline > lim.on_threshold)])
    w = int(limits.duty_window_s * RATE)
    assert (on[w:] - on[:-w]).max() <= limits.max_duty * w
    assert lim.report().duty_events > 0


def test_effect_cannot_raise_limits():
    from hapticfx.errors import EffectError

    hard = SafetyLimits(peak=0.8)
    assert hard.lowered(peak=0.5).peak == 0.5
    with pytest.raises(EffectError, match="would raise the actuator's hard limit"):
        hard.lowered(peak=0.9)
    with pytest.raises(EffectError, match="rms_window_s 60 would lengthen the actuator's RMS window 0.05"):
        hard.lowered(rms_window_s=60)  # a longer window lets short bursts through: weaker
    with pytest.raises(EffectError, match="unknown safety limit 'duty_window_s'"):
        hard.lowered(duty_window_s=1.0)
    assert hard.lowered(rms_window_s=0.01).hard is hard


def _worst_rms(x: np.ndarray, win: int) -> float:
    sq = np.concatenate([[0.0], np.cumsum(x * x)])
    return float(np.sqrt(np.max(sq[win:] - sq[:-win]) / win))


def test_a_shorter_effect_window_still_keeps_the_hard_window_within_its_limit():
    """The haptuator case: hard RMS 0.5 over 50 ms; a 50 Hz square wave at full scale."""
    rate = 48000.0
    hard = SafetyLimits(peak=1.0, rms=0.5, rms_window_s=0.05)
    t = np.arange(int(0.5 * rate)) / rate
    square = np.sign(np.sin(2 * np.pi * 50 * t))
    for window in (0.05, 0.03, 0.02, 0.007):
        limiter = SafetyLimiter(hard.lowered(rms_window_s=window), rate)
        out = np.concatenate([limiter.process(block) for block in np.array_split(square, 37)])
        assert _worst_rms(out, int(0.05 * rate)) <= 0.5 * (1 + 1e-9), window
        assert _worst_rms(out, int(window * rate)) <= 0.5 * (1 + 1e-9), window


@pytest.mark.parametrize("bad", [dict(peak=5.0), dict(peak=float("nan")), dict(rms=-0.1), dict(max_on_s=-1.0),
                                 dict(rms_window_s=0.0), dict(max_duty=2.0), dict(duty_window_s=float("inf"))])
def test_invalid_limits_are_refused_when_made(bad):
    from hapticfx.errors import PluginError

    with pytest.raises(PluginError, match=f"invalid safety limits: {next(iter(bad))} must be a number in"):
        SafetyLimits(**bad)


def test_a_restored_state_limits_the_same_blocks_the_same_way():
    """What the sound-card queue relies on to limit queued audio again: from a state taken before,
    the same blocks come out the same, events and duty history included."""
    limits = SafetyLimits(peak=0.8, rms=0.3, rms_window_s=0.05, max_on_s=0.03, max_duty=0.5, duty_window_s=0.2)
    lim = SafetyLimiter(limits, RATE)
    rng = np.random.default_rng(3)
    lim.process(rng.uniform(-2, 2, 40))
    state = lim.state()
    blocks = [rng.uniform(-2, 2, 25) for _ in range(4)]
    first = [lim.process(b, at_s=0.05 + 0.03 * i) for i, b in enumerate(blocks)]
    report = lim.report()
    lim.process(rng.uniform(-2, 2, 60))  # what came after is forgotten by the restore
    lim.restore(state)
    again = [lim.process(b, at_s=0.05 + 0.03 * i) for i, b in enumerate(blocks)]
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)
    assert lim.report() == report and report.total > 0


@pytest.mark.parametrize("limits", [
    SafetyLimits(peak=1.0, rms=0.7, rms_window_s=0.05),  # only the peak limit acts (from 1.5)
    SafetyLimits(peak=1.0, rms=0.3, rms_window_s=0.05),  # the RMS limit acts (from 0.6)
    SafetyLimits(peak=0.8, rms=0.3, rms_window_s=0.05, max_on_s=0.03, max_duty=0.5, duty_window_s=0.2),
])
@pytest.mark.parametrize("amp", [0.2, 0.6, 1.5, 3.0])
def test_a_run_of_blocks_at_once_is_the_same_as_block_by_block(limits, amp):
    """What the sound-card queue limits its queued audio with: output, events and the state before
    each block as from process() called block by block, gaps of silence between runs included."""
    one, many = SafetyLimiter(limits, RATE), SafetyLimiter(limits, RATE)
    t = 0.0
    for run in range(4):
        x = np.random.default_rng(run).uniform(-amp, amp, 64 * 5 + 7)
        got, states = many.process_blocks(x, block=64, at_s=t)
        want, want_states = [], []
        for k in range(0, x.size, 64):
            want_states.append(one.state())
            want.append(one.process(x[k:k + 64], at_s=t + k / RATE))
        np.testing.assert_array_equal(got, np.concatenate(want))
        assert len(states) == len(want_states)
        for s, w in zip(states, want_states):
            tail, history, clock, counts, reduction, pulse = s
            np.testing.assert_array_equal(tail, w[0])
            assert (history, counts, reduction, pulse) == (w[1], w[3], w[4], w[5])
            assert clock == pytest.approx(w[2], abs=1e-12)
        assert one.report() == many.report()
        t += x.size / RATE + 0.01 * run  # then a gap of silence


def _splice(out: np.ndarray, cuts: list[tuple[int, int]]) -> np.ndarray:
    """``out`` as a device that cut ``(where, how many)`` samples out of it plays it: the rest joined, no
    silence in between (what a sound server did around underruns, issue 31)."""
    keep = np.ones(out.size, dtype=bool)
    for where, n in cuts:
        keep[where:where + n] = False
    return out[keep]


@settings(max_examples=80, deadline=None)
@given(st.lists(arrays(np.float64, st.integers(1, 40), elements=st.floats(-5, 5)), min_size=3, max_size=10),
       st.lists(st.tuples(st.integers(0, 300), st.integers(1, 3)), max_size=4))
def test_rms_holds_where_the_device_cuts_up_to_the_splice_out_of_each_window(blocks, cuts):
    """20-sample window, 3-sample splice: with at most 3 samples cut from any stretch of 23, what the device
    plays holds the limit (cuts spread so that no 23-sample stretch loses more than 3)."""
    limits = SafetyLimits(peak=1.0, rms=0.3, rms_window_s=0.02)
    lim = SafetyLimiter(limits, RATE, splice_s=0.003)
    out = np.concatenate([lim.process(b) for b in blocks])
    spaced, last = [], -10**9
    for where, n in sorted(cuts):
        if where >= last + 23:  # one cut per 23 samples: no window of 20 played spans more than 23 of ours
            spaced.append((where, n))
            last = where + n
    played = _splice(out, spaced)
    if len(played) >= 20:
        assert np.max(windowed_rms(played, 20)) <= 0.3 * (1 + 1e-9)


def test_without_a_splice_allowance_a_cut_brings_a_window_over_the_limit():
    """The case the allowance is for: a burst, a quiet stretch, a burst, each block as loud as its windows
    allow; the device cuts part of the quiet stretch out and the bursts come closer: over the limit, unless
    the limiter left room for the cut."""
    blocks = [np.full(10, 5.0), np.zeros(10), np.full(10, 5.0)]
    cut = [(10, 3)]
    limits = SafetyLimits(peak=1.0, rms=0.3, rms_window_s=0.02)
    plain = SafetyLimiter(limits, RATE)
    out = np.concatenate([plain.process(b) for b in blocks])
    assert np.max(windowed_rms(out, 20)) <= 0.3 * (1 + 1e-9)
    assert np.max(windowed_rms(_splice(out, cut), 20)) > 0.3 * 1.05
    guarded = SafetyLimiter(limits, RATE, splice_s=0.003)
    out = np.concatenate([guarded.process(b) for b in blocks])
    assert np.max(windowed_rms(_splice(out, cut), 20)) <= 0.3 * (1 + 1e-9)
    steady = guarded.process(np.full(200, 5.0))  # what the allowance costs a steady output: sqrt(20 / 23)
    assert np.max(windowed_rms(steady, 20)) == pytest.approx(0.3 * np.sqrt(20 / 23), rel=1e-6)
