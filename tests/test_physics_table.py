"""Physics tables: the contact model served from a velocity table equals direct integration, at the edges too."""

from __future__ import annotations

import numpy as np
import pytest

from hapticfx.errors import SignalError
from hapticfx.interfaces import Impact
from hapticfx.models import physics_table
from hapticfx.params import BuildContext, parse_params
from hapticfx.registry import get_registry

# short profiles keep every table build here to a few seconds
SMALL = {"duration_ms": 20.0, "pre_ms": 1.0, "felt": "receiver", "receiver": "tabletop", "max_velocity_mps": 2.0}


@pytest.fixture(autouse=True)
def own_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("HAPTICFX_CACHE", str(tmp_path_factory.getbasetemp() / "physics-cache"))


def build(mapping, object_id="wood-beam", info=None):
    from hapticfx.objects import PAPER_OBJECTS

    cls = get_registry().get("model", "contact").resolve()
    params = parse_params(cls.Params, {**SMALL, **mapping}, source="fx.yaml", key="model")
    return cls(params, BuildContext(source="fx.yaml", object_id=object_id,
                                    object_info=info or PAPER_OBJECTS[object_id]))


def pair(mapping):
    """The same effect served from its table and integrated at every impact."""
    return build(mapping), build({**mapping, "table": False})


@pytest.mark.parametrize("felt", ["receiver", "striker", pytest.param("sensor", marks=pytest.mark.slow)])
def test_the_table_equals_direct_integration_within_1e_6_of_the_peak(felt):
    table, direct = pair({"felt": felt})
    tab = table.table_for(table.object_for("wood-beam"))
    rng = np.random.default_rng(1)
    for v in rng.uniform(tab.velocities[0], tab.v_max, size=6):
        got = table.render(Impact("wood-beam", v)).samples
        ref = direct.render(Impact("wood-beam", v)).samples
        assert np.max(np.abs(got - ref)) <= 1e-6 * np.max(np.abs(ref)), v


def test_a_table_is_built_once_then_read_from_the_cache_and_tied_to_the_parameters():
    a = build({})
    t = a.table_for(a.object_for("wood-beam"))
    again = build({}).table_for(a.object_for("wood-beam"))
    assert again.table.path == t.table.path and again.table.path.is_file()
    other = build({"stiffness": 3.1e6}).table_for(a.object_for("wood-beam"))
    assert other.source != t.source and other.table.path != t.table.path


def test_a_table_is_tied_to_what_strikes_not_only_to_its_id(monkeypatch):
    """A stylus on rubber and on aluminium (one object id, another material) never share a table."""
    from dataclasses import replace

    from hapticfx.objects import PAPER_OBJECTS

    sources = []

    def record(obj, profile, *, source, **kwargs):
        sources.append(source)
        raise LookupError("recorded")

    monkeypatch.setattr(physics_table, "build", record)
    beam = PAPER_OBJECTS["wood-beam"]
    for info in (beam, replace(beam, material="aluminium"), replace(beam, mass_kg=2 * beam.mass_kg)):
        model = build({"duration_ms": 21.0}, info=info)  # a table no other test builds
        with pytest.raises(LookupError):
            model.table_for(model.object_for("wood-beam"))
    assert len(set(sources)) == 3


def test_rendering_from_a_table_integrates_nothing(monkeypatch):
    model = build({})
    model.table_for(model.object_for("wood-beam"))
    from hapticfx.droprig import contact

    def refuse(*a, **k):
        raise AssertionError("the ODE was solved for an impact")

    monkeypatch.setattr(contact.DropScene, "sample", refuse)
    for v in (0.0, 1e-9, 0.3, 2.0):
        assert np.all(np.isfinite(model.render(Impact("wood-beam", v)).samples))


# k = 1e10 takes minutes to tabulate (`hapticfx bench physics` builds it, docs/families.md gives the time); here
# the stiffest cases are integrated directly and the tables are checked at the soft end
@pytest.mark.parametrize("mass, stiffness, served", [
    pytest.param(1e-3, 1e3, "table", marks=pytest.mark.slow), pytest.param(10.0, 1e3, "table", marks=pytest.mark.slow),
    (1e-6, 1e10, "direct"), (1e-3, 1e10, "direct"), (10.0, 1e10, "direct"),
    (1e-6, 1e3, "direct"), (1e-3, 1e3, "direct"), (10.0, 1e3, "direct")])
def test_edges_finite_bounded_continuous_and_a_clear_error_past_the_range(mass, stiffness, served):
    table, direct = pair({"mass_kg": mass, "stiffness": stiffness, "table": served == "table"})
    v_max = 2.0
    for model in (table, direct) if served == "table" else (direct,):
        peaks = []
        for v in (0.0, 1e-9, 1e-6, v_max * physics_table.FLOOR, 0.37 * v_max, v_max):
            s = model.render(Impact("wood-beam", v)).samples
            assert np.all(np.isfinite(s))
            peaks.append(np.max(np.abs(s)))
        assert peaks[0] == 0.0 and peaks[1] < 1e-6 * peaks[-1]
        # bounded by momentum: an impulse of at most 2 m v moves the rigid body and each mode (participation p,
        # modal mass m_i) by at most twice what it would over one sample
        r = model.receiver_model()
        per_kg = 1.0 / r.mass + sum(abs(m.vertical) / m.mass for m in r.modes)
        assert peaks[-1] * 9.80665 <= 2 * (2 * mass * v_max) / 1e-3 * per_kg
        with pytest.raises(SignalError, match=r"past this effect's range \(0 to 2 m/s\).*max_velocity_mps") as err:
            model.render(Impact("wood-beam", v_max * (1 + 1e-9)))
        assert err.value.source == model.context.source  # the effect file that sets the range
    if served != "table":
        return
    # continuous: either side of every knot and of the floor, the table moves by a hair
    for k in table.table_for(table.object_for("wood-beam")).velocities[:-1]:
        below = table.render(Impact("wood-beam", k * (1 - 1e-9))).samples
        above = table.render(Impact("wood-beam", k * (1 + 1e-9))).samples
        assert np.max(np.abs(above - below)) <= 1e-6 * max(np.max(np.abs(above)), 1e-300)


def test_knots_cover_the_range_geometrically():
    k = physics_table.knots(2.0)
    assert k[-1] == 2.0 and k[0] == pytest.approx(2.0 * physics_table.FLOOR)
    assert np.allclose(k[1:] / k[:-1], physics_table.RATIO)


def test_a_range_the_table_cannot_follow_is_integrated_directly_not_served_from_its_line():
    """A table whose interval did not converge served a straight line there: 0.104 of the peak from direct
    integration at 1 m/s for a 10 kg block at k = 1e10 (a 227 s build). Here a profile with a step in velocity
    stands for such a range."""
    model = build({})
    info = model.object_for("wood-beam")
    n = model.n_samples

    def stepped(v):  # no polynomial in velocity follows it across 1.3 m/s
        return np.full(n, v * (2.0 if v > 1.3 else 1.0))

    table = physics_table.build(info.id, stepped, v_max=2.0, rate_hz=model.params.rate_hz, source="x",
                                reducer="felt:receiver")
    (a, b), = [r for r in table.unconverged if r[0] < 1.3 < r[1]]
    assert not table.served_at(1.3) and table.served_at(a) and table.served_at(0.5)
    model._tables[info.id] = table
    v = float(np.sqrt(a * b))
    assert np.array_equal(model.render(Impact("wood-beam", v)).samples, model._profile(info, v))
    assert np.array_equal(model.render(Impact("wood-beam", 0.5)).samples, table.profile(0.5))
