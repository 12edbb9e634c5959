"""The texture: the fine detail a profile keeps of its recorded neighbours, and how much (ensemble-warp's choice of
it on data: tests/test_interpolator_ensemble_warp.py)."""

from __future__ import annotations

import numpy as np

from hapticfx.interpolators.texture import KEEP_SHARE, TEXTURE_HZ, Target, choose, fine, keep

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
    beta, scores = choose([_target(k, 0.3) for k in range(12)])
    assert beta > 0.0 and scores[str(beta)]["spqi"] > scores["0.0"]["spqi"]
    assert scores[str(beta)]["share"] >= KEEP_SHARE and scores["0.8"]["share"] < KEEP_SHARE  # not the most detail
    assert set(scores) == {"linear", "0.0", "0.2", "0.4", "0.6", "0.8"}
    assert choose([_target(k, 0.0) for k in range(12)])[0] == 0.0  # every beta the same profile: the least
    assert choose([]) == (0.0, {})
