"""The streaming mixer without a device: sums, limiting of the sum, bounded voices, channels."""

import weakref

import numpy as np
import pytest
from hapticfx.errors import SignalError
from hapticfx.interfaces import SafetyLimits

from hapticfx_soundcard.mixer import Mixer

RATE = 48000.0
LOOSE = SafetyLimits(peak=1.0, rms=1.0)


def render(mixer, frames, block):
    out = np.zeros((frames, mixer.channels), dtype=np.float32)
    buf = np.zeros((block, mixer.channels), dtype=np.float32)
    for start in range(0, frames, block):
        mixer.render_into(buf)
        n = min(block, frames - start)
        out[start:start + n] = buf[:n]
    return out


def burst(n, f, amp, seed=0):
    t = np.arange(n) / RATE
    return amp * np.exp(-t * 20) * np.sin(2 * np.pi * f * t + seed)


@pytest.mark.parametrize("block", [1, 37, 256, 4096])
def test_overlapping_impacts_add_up_exactly(block):
    a, b = burst(3000, 100, 0.3), burst(2000, 250, 0.2, seed=1)
    mixer = Mixer(1, RATE)
    mixer.set_limits(0, LOOSE)
    mixer.add(0, a)
    first = render(mixer, block * 3, block)  # b starts three blocks later
    mixer.add(0, b)
    rest = render(mixer, 6000, block)
    got = np.concatenate([first, rest])[:, 0].astype(np.float64)
    ref = np.zeros(got.size)
    ref[:a.size] += a
    ref[block * 3:block * 3 + b.size] += b
    np.testing.assert_allclose(got, ref, atol=1e-6)  # float32 output
    assert not mixer.busy


def test_sum_of_limited_impacts_is_limited_again():
    limits = SafetyLimits(peak=0.5, rms=0.7)
    mixer = Mixer(1, RATE)
    mixer.set_limits(0, limits)
    for _ in range(4):  # each within the limit, together 4x over it
        mixer.add(0, np.full(480, 0.45))
    out = render(mixer, 960, 128)
    assert np.max(np.abs(out)) <= 0.5 + 1e-7
    assert mixer.report(0).peak_events > 0


def test_voices_are_bounded_and_those_beyond_are_refused():
    mixer = Mixer(1, RATE, max_voices=4)
    mixer.set_limits(0, LOOSE)
    taken = [mixer.add(0, np.full(1000, 0.01 * (i + 1))) for i in range(10)]
    out = render(mixer, 64, 64)
    assert taken == [True] * 4 + [False] * 6 and mixer.refused == 6
    np.testing.assert_allclose(out[:, 0], 0.01 * (1 + 2 + 3 + 4), atol=1e-6)
    render(mixer, 1000, 64)  # they end: room again
    assert mixer.voices == 0 and mixer.add(0, np.ones(10) * 0.1)


def test_the_queue_is_bounded_before_rendering_too():
    mixer = Mixer(1, RATE, max_voices=8)
    mixer.set_limits(0, LOOSE)
    for i in range(1000):  # no block rendered meanwhile (a stalled device)
        mixer.add(0, np.full(100, 1e-4 * i))
    assert mixer.voices == 8 and mixer.refused == 992
    out = render(mixer, 64, 64)
    np.testing.assert_allclose(out[:, 0], 1e-4 * sum(range(8)), rtol=1e-5)


def test_channels_stay_separate_and_silence_is_exact():
    mixer = Mixer(2, RATE)
    mixer.set_limits(0, LOOSE)
    mixer.set_limits(1, LOOSE)
    mixer.add(1, np.full(100, 0.25))
    out = render(mixer, 300, 64)
    assert np.all(out[:, 0] == 0)
    np.testing.assert_allclose(out[:100, 1], 0.25)
    assert np.all(out[100:, 1] == 0)


def test_channel_without_limits_is_refused():
    mixer = Mixer(2, RATE)
    with pytest.raises(SignalError, match="no safety limits"):
        mixer.add(1, np.ones(10))


def test_a_block_costs_the_same_however_many_voices_sound():
    """1,000 overlapping impacts: the block is their sum (the ring), not a loop over them; no impact's
    samples are kept once summed."""
    mixer = Mixer(1, RATE, max_voices=1000)
    mixer.set_limits(0, LOOSE)
    rng = np.random.default_rng(0)
    voices = rng.uniform(-1e-4, 1e-4, (1000, 4800))
    for v in voices:
        mixer.add(0, v)
    assert mixer.voices == 1000 and mixer.refused == 0
    out = render(mixer, 4800, 48)
    np.testing.assert_allclose(out[:, 0], voices.sum(axis=0), atol=1e-6)  # float32 output
    assert not mixer.busy
    x = np.full(4800, 1e-4)
    alive = weakref.ref(x)
    mixer.add(0, x)
    del x
    assert alive() is None  # summed into the ring, not kept
