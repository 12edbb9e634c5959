"""The texture: the fine detail a profile keeps of its recorded neighbours, and how much (ensemble-warp's choice of
it on data: tests/test_interpolator_ensemble_warp.py)."""

from __future__ import annotations

import numpy as np

from hapticfx.interpolators.texture import (FILLS, KEEP_SHARE, TEXTURE_HZ, Target, choose, fill, fine, keep,
                                            textured)

N = 200


def _pulse(at: float, width: float = 2.5, height: float = 1.0) -> np.ndarray:
    return height * np.exp(-0.5 * ((np.arange(N) - at) / width) ** 2)


def test_fine_keeps_the_detail_in_place_and_drops_the_slow_pulse():
    t = np.arange(N) / 1000.0
    pulse = _pulse(100, width=10.0)
    burst = np.sin(2 * np.pi * 300 * (t - 0.1)) * np.exp(-0.5 * ((t - 0.1) / 0.01) ** 2)
    out = fine(pulse + burst, 1000.0)
    assert np.abs(fine(pulse, 1000.0)).max() < 5e-3  # nearly all of it below the corner
    assert np.allclose(out, burst, atol=0.03 * np.abs(burst).max())  # 300 Hz passes (gain 0.988), in place
    assert np.allclose(fine(2 * burst, 1000.0), 2 * fine(burst, 1000.0))
    f = np.fft.rfftfreq(4096, 1e-3)
    gain = np.abs(np.fft.rfft(fine(np.eye(N)[N // 2], 1000.0), 4096))
    assert np.isclose(np.interp(TEXTURE_HZ, f, gain), 0.5, atol=0.02)  # -6 dB at the corner
    assert np.all(np.isfinite(fine(np.zeros(N), 1000.0))) and not np.any(fine(np.zeros(N), 1000.0))


def test_keep_gives_back_beta_of_the_fine_detail_and_nothing_at_zero():
    rng = np.random.default_rng(1)
    diff = rng.standard_normal(N)
    assert keep(diff, 0.0, 1000.0) is diff
    assert np.allclose(keep(diff, 0.4, 1000.0), diff - 0.4 * fine(diff, 1000.0))


def _drops(rng, count: int, ring: float) -> np.ndarray:
    """Drops that share a slow pulse and each ring at 180-260 Hz with its own phase (``ring`` 0: the pulse alone)."""
    t = np.arange(N) / 1000.0
    return np.stack([_pulse(30, width=8.0) + ring * np.sin(2 * np.pi * rng.uniform(180, 260) * t + rng.uniform(0, 6.3))
                     * np.exp(-t / 0.05) for _ in range(count)])


def _target(seed: int, ring: float) -> Target:
    """A target halfway between two neighbours of 6 drops each: the blend of their first drops (the
    representatives), drawn to the blend of their means, which keeps little of the ringing every drop has."""
    rng = np.random.default_rng(seed)
    lower, upper, drops = _drops(rng, 6, ring), _drops(rng, 6, ring), _drops(rng, 8, ring)
    blend = 0.5 * (lower[0] + upper[0])
    centre = 0.5 * (lower.mean(axis=0) + upper.mean(axis=0))
    return Target(0.5, blend, centre - blend, drops, drops.mean(axis=0), drops[0], 1000.0)


def test_the_choice_keeps_detail_the_centre_lost_and_none_where_there_is_none():
    (beta, g), scores = choose([_target(k, 0.3) for k in range(12)])
    assert g == 0.0 and beta > 0.0 and scores[str(beta)]["spqi"] > scores["0.0"]["spqi"]
    assert scores[str(beta)]["share"] >= KEEP_SHARE and scores["0.8"]["share"] < KEEP_SHARE  # not the most detail
    assert set(scores) == {"linear", "0.0", "0.2", "0.4", "0.6", "0.8"}
    assert choose([_target(k, 0.0) for k in range(12)])[0] == (0.0, 0.0)  # every beta the same profile: the least
    assert choose([]) == ((0.0, 0.0), {})


def test_fill_raises_the_quiet_bins_above_100_hz_and_moves_what_it_adds_to_where_the_reference_rings():
    t = np.arange(500) / 1000.0
    ring = np.sin(2 * np.pi * 230 * t) * np.exp(-t / 0.03)  # the reference rings at 230 Hz for the first ~100 ms
    pulse = np.where(t < 0.0125, np.sin(np.pi * t / 0.0125), 0.0)
    x = pulse + 0.1 * np.sin(2 * np.pi * 230 * t + 1.0) * np.exp(-t / 0.03)  # a tenth of it, in another phase
    added = fill(x, ring, 0.5, 1000.0) - x
    # what the bins raised in x's phase add, before it is moved: its energy is kept
    X, R = np.fft.rfft(x), np.fft.rfft(ring)
    low = (np.fft.rfftfreq(500, 1e-3) > 100.0) & (np.abs(X) < 0.5 * np.abs(R))
    assert low.sum() > 10  # the case is not empty
    raised = np.fft.irfft(np.where(low, 0.5 * np.abs(R) * X / np.abs(X) - X, 0.0), 500)
    np.testing.assert_allclose(np.sum(added ** 2), np.sum(raised ** 2), rtol=1e-9)
    assert np.sum(raised[300:] ** 2) > 0.005 * np.sum(raised ** 2)  # left where it fell, some reaches the tail
    assert np.sum(added[300:] ** 2) < 1e-6 * np.sum(added ** 2)  # moved: none does
    spectrum, freqs = np.abs(np.fft.rfft(added, 2000)) ** 2, np.fft.rfftfreq(2000, 1e-3)
    assert spectrum[freqs < 80].sum() < 0.01 * spectrum.sum()  # nothing below 100 Hz to speak of
    near = spectrum[(freqs > 200) & (freqs < 260)].sum()
    assert near > 0.8 * spectrum.sum()  # the ring's band, where x was quiet
    np.testing.assert_array_equal(fill(x, ring, 0.0, 1000.0), x)
    silent = fill(np.zeros(500), ring, 0.5, 1000.0)  # a silent x takes the reference's phase
    assert np.all(np.isfinite(silent)) and np.abs(silent).max() > 0.01
    np.testing.assert_array_equal(fill(x, np.zeros(500), 0.5, 1000.0), x)  # a silent reference: nothing to raise
    np.testing.assert_allclose(fill(np.stack([x, x]), ring, 0.5, 1000.0)[1], x + added, atol=1e-12)  # row by row


def test_textured_keeps_then_fills_the_centre_and_is_keep_without_a_fill():
    rng = np.random.default_rng(4)
    blend, diff = rng.standard_normal((2, N))
    np.testing.assert_array_equal(textured(diff, blend, 0.4, 0.0, 1000.0), keep(diff, 0.4, 1000.0))
    np.testing.assert_allclose(textured(diff, blend, 0.4, 0.5, 1000.0),
                               fill(blend + keep(diff, 0.4, 1000.0), blend, 0.5, 1000.0) - blend, atol=1e-12)


def test_a_fill_chosen_with_the_share_is_the_admissible_pair_of_most_expected_criteria():
    targets = [_target(k, 0.3) for k in range(12)]
    (beta, g), scores = choose(targets, fills=FILLS)
    pairs = [(b, f) for b in (0.0, 0.2, 0.4, 0.6, 0.8) for f in FILLS]
    name = {p: str(p[0]) if not p[1] else f"{p[0]} fill {p[1]}" for p in pairs}
    assert set(scores) == {"linear", *name.values()}
    admissible = [p for p in pairs if p == (0.0, 0.0) or scores[name[p]]["share"] >= KEEP_SHARE]
    assert (beta, g) in admissible
    assert scores[name[(beta, g)]]["expected_criteria"] == max(scores[name[p]]["expected_criteria"] for p in admissible)
    # the fill buys log-spectral distance at an RMSE cost, more of both the higher it fills
    lsd = [scores[name[(0.0, f)]]["lsd"] for f in FILLS]
    rmse = [scores[name[(0.0, f)]]["rmse_mean"] for f in FILLS]
    assert np.all(np.diff(lsd) < 0) and np.all(np.diff(rmse) > 0)
    # a fixed share: only the fill is chosen; the first pair (no fill) is always admissible
    (b2, _), fixed = choose(targets, betas=(0.8,), fills=FILLS)
    assert b2 == 0.8 and set(fixed) == {"linear", "0.8", *(f"0.8 fill {f}" for f in FILLS[1:])}
