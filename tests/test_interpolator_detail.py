"""The detail a mean of drops loses, given back to ensemble-warp's centres: the filter, its edges, its choice."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.data.bank import ProfileBank
from hapticfx.errors import HapticfxError
from hapticfx.evaluation.measures import log_spectral_distance
from hapticfx.evaluation.protocol import SHARE
from hapticfx.interfaces import TrainingData
from hapticfx.interpolators import detail
from hapticfx.interpolators.ensemble_warp import EnsembleWarpInterpolator, Fit
from hapticfx.processing.representative import medoid

N, RATE = 500, 1000.0
T = np.arange(N) / RATE


def _band_power(x, lo, hi):
    f = np.fft.rfftfreq(N, 1 / RATE)
    return float(np.sum(np.abs(np.fft.rfft(x, axis=-1))[..., (f >= lo) & (f <= hi)] ** 2, axis=-1).mean())


def _ringing_drops(ring: float, drops: int = 10, seed: int = 0, velocities=np.linspace(2.0, 5.0, 7)):
    """A pulse that moves and narrows with velocity, shared by every drop, and a 200 Hz ringing of amplitude
    ``ring`` x velocity whose phase differs from drop to drop (their mean keeps little of it)."""
    rng = np.random.default_rng(seed)
    v = np.asarray(velocities, dtype=np.float64)
    shared = np.stack([x * np.exp(-0.5 * ((np.arange(N) - 40 - 4 * x) / (6 - x)) ** 2) for x in v])
    phase = rng.uniform(0, 2 * np.pi, (len(v), drops, 1))
    envelope = np.exp(-np.maximum(T - 0.05, 0) / 0.05) * (T >= 0.05)
    d = (shared[:, None, :] + ring * v[:, None, None] * envelope * np.sin(2 * np.pi * 200 * T + phase)
         + 0.002 * rng.standard_normal((len(v), drops, N)))
    return v, d


def _data(ring: float) -> TrainingData:
    v, d = _ringing_drops(ring)
    bank = ProfileBank("brick", "max-min", RATE, v, np.stack([x[medoid(x)] for x in d]))
    return TrainingData({"brick": bank}, "max-min", "synthetic", {"brick": (v, d)})


def test_no_detail_and_unit_gain_leave_the_centre_as_it_is():
    v, d = _ringing_drops(0.1)
    pd, pc = detail.power(d[:2], RATE).mean(axis=1), detail.power(d[:2].mean(axis=1), RATE)
    assert np.array_equal(detail.gain(pd[0], pd[1], pc[0], pc[1], 0.4, 0.0), np.ones_like(pd[0]))
    centre = d[0].mean(axis=0)
    assert np.allclose(detail.restore(centre, np.ones(detail.n_fft(N) // 2 + 1)), centre, rtol=0, atol=1e-12)


def test_the_ringing_the_mean_lost_comes_back_and_the_shared_pulse_stays():
    v, d = _ringing_drops(0.1)
    drops, centre = d[3], d[3].mean(axis=0)
    pd, pc = detail.power(drops, RATE).mean(axis=0), detail.power(centre, RATE)
    full = detail.restore(centre, detail.gain(pd, pd, pc, pc, 0.5, 1.0))
    half = detail.restore(centre, detail.gain(pd, pd, pc, pc, 0.5, 0.5))
    lost, kept = _band_power(drops, 180, 220), _band_power(centre, 180, 220)
    assert kept < 0.3 * lost  # the mean of 10 random phases keeps about a tenth
    assert 0.6 * lost < _band_power(full, 180, 220) < 1.5 * lost  # alpha 1: the drops' power back
    assert kept < _band_power(half, 180, 220) < _band_power(full, 180, 220)
    assert _band_power(full, 0, 60) == pytest.approx(_band_power(centre, 0, 60), rel=0.02)  # the pulse is shared
    assert np.all(np.isfinite(full)) and np.abs(full).max() < 1.2 * np.abs(drops).max()


def test_the_gain_is_bounded_and_silence_stays_silent():
    pd, pc = np.full(513, 1e3), np.zeros(513)  # a centre that kept nothing at all
    g = detail.gain(pd, pd, pc, pc, 0.5, 1.0)
    assert np.all(g == np.sqrt(detail.MAX_GAIN))
    silence = np.zeros((3, N))
    ps = detail.power(silence, RATE)
    assert np.array_equal(detail.restore(silence[0], detail.gain(ps[0], ps[1], ps[0], ps[1], 0.5, 1.0)), silence[0])


def _check_the_rule(fit: Fit):
    """The chosen share of detail is admissible (keeps SHARE of the gap, or is 0) and the least admissible one
    that is no worse than linear spectrally: every measure, else log-spectral distance, else 0."""
    s, lin = fit.detail_scores, fit.detail_scores["linear"]
    admissible = [a for a in detail.ALPHAS if a == 0.0 or s[str(a)]["share"] >= SHARE]

    def ok(a, keys):
        return all(s[str(a)][k] <= lin[k] if k == "lsd" else s[str(a)][k] >= lin[k] for k in keys)

    expected = next((a for keys in (("lsd", "stsim", "spqi"), ("lsd",)) for a in admissible if ok(a, keys)), 0.0)
    assert fit.detail == expected


def test_the_detail_is_given_back_where_the_mean_lost_what_every_drop_rings_with():
    fit = Fit(_data(0.1))
    _check_the_rule(fit)
    assert fit.detail > 0.0
    s = fit.detail_scores
    assert s["0.0"]["lsd"] > s["linear"]["lsd"]  # the plain centres are duller than a blend of two drops
    assert s[str(fit.detail)]["lsd"] <= s["linear"]["lsd"]
    # served as fitted: the profile between two velocities carries the ringing back, at a bounded level
    warp, plain = EnsembleWarpInterpolator(), EnsembleWarpInterpolator(detail=0.0)
    data = _data(0.1)
    warp.fit(data)
    plain.fit(data)
    lo, hi = data.banks["brick"][2], data.banks["brick"][3]
    v = 0.5 * (lo.velocity + hi.velocity)
    rich, dull = warp.interpolate(lo, hi, v), plain.interpolate(lo, hi, v)
    _, drops = _ringing_drops(0.1, velocities=[v])
    assert _band_power(rich, 180, 220) > 2 * _band_power(dull, 180, 220)
    assert np.mean(log_spectral_distance(rich, drops[0])) < np.mean(log_spectral_distance(dull, drops[0]))
    assert np.all(np.isfinite(rich)) and np.abs(rich).max() < 1.5 * np.abs(drops).max()


def test_no_detail_is_given_back_when_it_would_cost_the_gap_to_the_drop_mean():
    # ringing so strong that only the whole of it makes the centres as rich as linear's drops, and that costs
    # more than 1 - SHARE of the gap: the centres stay as they are
    fit = Fit(_data(0.2))
    _check_the_rule(fit)
    assert fit.detail == 0.0
    assert fit.detail_scores["1.0"]["share"] < SHARE and fit.detail_scores["0.0"]["lsd"] > fit.detail_scores[
        "linear"]["lsd"]


def test_nothing_lost_nothing_given_back():
    fit = Fit(_data(0.0))
    _check_the_rule(fit)
    assert fit.detail == 0.0


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), "half"])
def test_a_detail_option_outside_0_to_1_is_refused_by_name(bad):
    with pytest.raises(HapticfxError, match="interpolator_options.detail"):
        EnsembleWarpInterpolator(detail=bad)


def test_a_fixed_detail_replaces_the_fitted_choice():
    fit = Fit(_data(0.1), detail=0.25)
    assert fit.detail == 0.25 and fit.detail_scores is None
    assert fit.summary()["detail"] == 0.25


def test_an_effect_that_fixes_the_detail_is_not_served_the_shipped_table_fitted_with_another():
    from hapticfx.data.dataset import open_dataset
    from hapticfx.interpolators.ensemble_warp import table_path
    from hapticfx.interpolators.table import VelocityTable

    ds = open_dataset("builtin:helmet-drops")
    bank = ds.bank(ds.objects[0], "max-min")
    shipped, fixed = EnsembleWarpInterpolator(), EnsembleWarpInterpolator(detail=0.0)
    for interp in (shipped, fixed):
        interp.prepare(bank, dataset=ds)
    on_file = VelocityTable.load(table_path(ds.path, "max-min")).meta["source"]["detail"]
    assert shipped.describe()["detail given back"] == on_file != 0.0  # the shipped table's fitted choice
    assert fixed.describe()["detail given back"] == 0.0  # fitted again, with the effect's value
    lo, hi = bank[3], bank[4]
    v = 0.5 * (lo.velocity + hi.velocity)
    assert not np.allclose(shipped.interpolate(lo, hi, v), fixed.interpolate(lo, hi, v))
