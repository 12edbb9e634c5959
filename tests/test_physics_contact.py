"""The contact physics: Hunt-Crossley law, drop integration against a float64 reference, extremes."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from hapticfx.droprig.contact import Block, DropScene
from hapticfx.droprig.state import JY, VH, VY, Y, YH
from hapticfx.droprig.hertz import G, hunt_crossley
from hapticfx.droprig.receiver import Receiver
from hapticfx.droprig.synth import Drop, Rig, scene_for, simulate_drop
from hapticfx.objects import PAPER_OBJECTS, ObjectInfo


def test_hunt_crossley_pushes_only_when_touching_and_never_pulls():
    f = hunt_crossley([-1e-3, 0.0, 1e-3, 1e-3, 1e-3], [0.0, 0.0, 0.0, 2.0, -100.0], stiffness=1e6, damping=0.5)
    assert f[0] == 0.0 and f[1] == 0.0
    assert f[2] == pytest.approx(1e6 * 1e-3**1.5)
    assert f[3] == pytest.approx(1e6 * 1e-3**1.5 * 2.0)
    assert f[4] == 0.0  # fast separation would pull: clamped


@pytest.mark.parametrize("object_id", list(PAPER_OBJECTS))
def test_default_integration_matches_tight_float64_reference(object_id):
    sc = scene_for(PAPER_OBJECTS[object_id], Drop(3.96, tilt=0.02, offset=0.003), Rig().helmet)
    grid = np.linspace(0.0, 0.2, 201)
    got = sc.integrate(0.2).sol(grid)
    ref = sc.integrate(0.2, method="DOP853", rtol=1e-11).sol(grid)
    assert np.max(np.abs(got[Y] - ref[Y])) < 5e-6  # metres, over a primary impact and its rebound
    assert np.max(np.abs(got[JY] - ref[JY])) < 1e-5 * np.max(np.abs(ref[JY]))


@pytest.mark.parametrize("method", ["RK45", "DOP853", "Radau", "BDF", "LSODA"])
def test_no_solver_steps_over_the_contact_at_loose_tolerance(method):
    # Free fall is exactly polynomial: without a step bound LSODA once jumped through the helmet.
    sc = scene_for(PAPER_OBJECTS["wood-beam"], Drop(3.96), Rig().helmet)
    sol = sc.integrate(0.1, method=method, rtol=1e-3)
    momentum = PAPER_OBJECTS["wood-beam"].mass_kg * 3.96
    assert -sol.y[JY, -1] > momentum  # the helmet was pushed down by at least the incoming momentum
    assert sol.y[Y].min() > -0.05  # and the block never passed through the dome


def _contact_time_and_restitution(velocity, damping):
    heavy = Receiver(mass=1e4)  # an immovable helmet: the textbook Hertz/Hunt-Crossley impact
    sc = DropScene(Block(0.1, 0.02, 0.01), heavy, stiffness=1e7, damping=damping, velocity=velocity, gap=1e-7)
    t = np.linspace(0.0, 0.004, 40001)
    states = sc.integrate(0.004, method="DOP853", rtol=1e-10).sol(t)
    touching = np.flatnonzero([sc.closest(states[:, i])[0] > 0 for i in range(0, len(t))])
    duration = (touching[-1] - touching[0] + 1) * (t[1] - t[0])
    return duration, states[VY, touching[-1] + 1] / velocity  # rebound speed at separation


def test_contact_time_and_restitution_follow_hertz_and_hunt_crossley():
    t_slow, e_elastic = _contact_time_and_restitution(1.0, 0.0)
    t_fast, _ = _contact_time_and_restitution(4.0, 0.0)
    assert e_elastic == pytest.approx(1.0, abs=2e-3)  # no damping: no loss
    assert t_fast / t_slow == pytest.approx(4.0 ** -0.2, rel=0.03)  # Hertz: duration ~ v^(-1/5)
    _, e_slow = _contact_time_and_restitution(1.0, 0.3)
    _, e_fast = _contact_time_and_restitution(4.0, 0.3)
    assert 0 < e_fast < e_slow < 1  # Hunt-Crossley: more loss at higher velocity


def test_velocity_zero_is_silence():
    acc = simulate_drop(PAPER_OBJECTS["steel-plate"], Drop(0.0))
    assert acc.shape[1] == 3 and not acc.any()


@pytest.mark.parametrize("mass,velocity,stiffness",
                         list(itertools.product([1e-3, 10.0], [0.01, 20.0], [1e3, 1e10])))
def test_simulator_finite_at_extremes(mass, velocity, stiffness):
    info = ObjectInfo("x", "x", mass, (50.0, 50.0, 20.0), "wood")
    acc = simulate_drop(info, Drop(velocity, tilt=0.02, offset=0.003, stiffness=stiffness, damping=0.26),
                        duration_s=0.3)
    assert np.all(np.isfinite(acc))
    # bounded by the momentum it can deliver: at most 2 m v (+ weight) per 50 us sample onto the helmet
    bound = (2 * mass * (velocity + 9.81 * 0.3) / 5e-5 + mass * 9.81) / 0.1
    assert np.abs(acc).max() < bound


def _tiny_strike(velocity, stiffness):
    """A 1 mg object struck as the contact model strikes it (no gravity, from the first contact)."""
    from hapticfx.droprig.family import Strike
    from hapticfx.droprig.receiver import named_receiver

    strike, info = Strike(stiffness=stiffness), ObjectInfo("grain", "grain", 1e-6, (1.0, 1.0, 1.0), "wood")
    return strike, strike.scene(info, strike.centre(info, velocity), named_receiver("helmet"))


def test_the_support_moves_the_helmet_below_the_preloads_last_bit():
    """The support's push less the helmet's weight cancelled to the rounding of the weight: a 1 mg impact moves
    the helmet by far less than the preload's last bit, so the solver chased rounding noise (1.2 million
    right-hand sides, 4 s, for one render at 1 mm/s) and the first 1e-20 m of a bounce was no force at all."""
    _, sc = _tiny_strike(1e-3, 1e3)
    s = sc.initial_state()
    s[YH] = 1e-20  # the crown up by 1e-20 m: the support pushes less, linearly
    assert sc.rhs(0.0, s)[VH] == pytest.approx(-1.5 * G * 1e-20 / sc.helmet.support_preload, rel=1e-9, abs=0)
    s[YH] = 0.0
    assert sc.rhs(0.0, s)[VH] == 0.0  # at rest on its support


@pytest.mark.parametrize("velocity,stiffness", [(1e-3, 1e3), (5.0, 1e3), (5.0, 1e10)])
def test_a_1_mg_impact_matches_a_tight_float64_reference(velocity, stiffness):
    from hapticfx.models.contact import RTOL

    strike, sc = _tiny_strike(velocity, stiffness)
    n, rate = 10000, 20000.0  # 500 ms, as the contact model renders
    got = sc.sample(n, rate, rtol=RTOL)
    assert sc.evaluations < 20_000  # the work a render does (tens of ms), not rounding noise chased
    ref = sc.integrate((n - 1) / rate, method="DOP853", rtol=1e-12).sol(np.arange(n) / rate)
    a, b = strike.acceleration(sc, got, rate), strike.acceleration(sc, ref, rate)
    assert np.all(np.isfinite(a)) and np.max(np.abs(a - b)) < 1e-6 * np.max(np.abs(b))


@pytest.mark.parametrize("mass_kg,hold_n", [(1e-3, 1000.0), (1e-6, 1.0)])
def test_a_striker_held_far_above_its_weight_renders_fast_and_as_a_tight_reference_does(mass_kg, hold_n):
    """A held striker's "gravity" is the hold force over its mass (1e6 m/s^2 here). The solver's step bound took
    the block's speed as what falling for the whole run gives, so steps shrank as the run went on: 1.6 and 2.5
    million right-hand sides for a 300 ms render (9 and 20 s), 182,000 and 272,000 for these 100 ms."""
    from hapticfx.droprig.family import Strike
    from hapticfx.droprig.receiver import named_receiver
    from hapticfx.models.contact import RTOL

    strike = Strike(hold_n=hold_n)
    info = ObjectInfo("pebble", "pebble", mass_kg, (5.0, 5.0, 5.0), "steel")
    sc = strike.scene(info, strike.centre(info, 1.0), named_receiver("helmet"))
    n, rate = 2000, 20000.0  # 100 ms
    got = sc.sample(n, rate, rtol=RTOL)
    assert sc.evaluations < 20_000
    ref = sc.integrate((n - 1) / rate, method="DOP853", rtol=1e-12).sol(np.arange(n) / rate)
    a, b = strike.acceleration(sc, got, rate), strike.acceleration(sc, ref, rate)
    assert np.all(np.isfinite(a)) and np.max(np.abs(a - b)) < 1e-5 * np.max(np.abs(b))
