"""Where on the head: the helmet layout of a scene, the spatialiser's gains and delays, and the engine's head
output (one actuator per site, each limited, every block of one length)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from hapticfx.engine import Engine
from hapticfx.errors import EffectError
from hapticfx.scene import load_scene, scene_from_mapping
from hapticfx.spatial import HeadLayout, Site, Spatialiser

ROOT = Path(__file__).resolve().parents[1]
HELMET = ROOT / "scenes" / "helmet_4.yaml"
R = 0.13


def helmet() -> Spatialiser:
    return Spatialiser(load_scene(HELMET).head)


def gains(sp: Spatialiser, **where) -> np.ndarray:
    g = np.zeros(len(sp.layout.sites))
    for p in sp.place(**where):
        g[p.site] = p.gain
    return g


def test_a_contact_on_a_site_plays_there_alone():
    sp = helmet()
    for k, site in enumerate(sp.layout.sites):
        expected = np.eye(4)[k]
        assert np.array_equal(gains(sp, point=site.position), expected)
        assert np.array_equal(gains(sp, normal=site.position), expected)  # a normal gives the direction too
        assert np.array_equal(gains(sp, channel=site.channel), expected)  # no point: the channel's site
    assert np.array_equal(gains(sp), np.eye(4)[0])  # nothing: the crown, where the paper's actuator sits


def test_between_two_sites_the_energy_is_shared_and_preserved():
    sp = helmet()
    crown, front = (np.array(s.position) / np.linalg.norm(s.position) for s in sp.layout.sites[:2])
    span = math.acos(float(crown @ front))
    for beta in (0.1, 0.25, 0.5, 0.75, 0.9):
        # the point at fraction beta of the arc from the crown to the front
        axis = np.cross(crown, front) / math.sin(span)
        point = crown * math.cos(beta * span) + np.cross(axis, crown) * math.sin(beta * span)
        g = gains(sp, point=tuple(R * point))
        assert g[0] == pytest.approx(math.sqrt(1 - beta), abs=1e-9) and g[1] == pytest.approx(math.sqrt(beta), abs=1e-9)
        assert g[2] == g[3] == 0 and (g ** 2).sum() == pytest.approx(1.0, abs=1e-12)
    halfway = gains(sp, point=tuple(R * (crown + front) / np.linalg.norm(crown + front)))
    assert 20 * math.log10(halfway[0]) == pytest.approx(-3.0103, abs=1e-3) and halfway[0] == pytest.approx(halfway[1])


def test_energy_is_one_and_gains_bounded_anywhere_on_the_head():
    sp = helmet()
    rng = np.random.default_rng(3)
    for d in rng.normal(size=(2000, 3)):
        g = gains(sp, point=tuple(d * rng.uniform(0.01, 10)))
        assert np.all((g >= 0) & (g <= 1)) and (g ** 2).sum() == pytest.approx(1.0, abs=1e-12)
        assert np.count_nonzero(g) <= 2


def test_a_contact_beyond_the_nearest_site_is_not_panned_past_it():
    sp = helmet()
    assert np.array_equal(gains(sp, point=(0.0, R, 0.0)), np.eye(4)[1])    # the face, below the front actuator
    assert np.array_equal(gains(sp, point=(R, 0.0, -0.02)), np.eye(4)[3])  # the right ear, below its actuator


def test_onset_delays_follow_the_surface_distance_over_the_wave_speed():
    sites = (Site("a", (0.0, 0.0, 0.1), 0), Site("b", (0.0, 0.1, 0.0), 1))
    sp = Spatialiser(HeadLayout("helmet", sites, wave_speed_mps=50.0))
    near_a = (0.0, 0.1 * math.sin(0.2), 0.1 * math.cos(0.2))  # 0.2 rad from a, pi/2 - 0.2 from b
    first, second = sp.place(point=near_a)
    assert (first.site, first.delay_s) == (0, 0.0)
    assert second.site == 1 and second.delay_s == pytest.approx(0.1 * (math.pi / 2 - 0.4) / 50.0)
    assert all(p.delay_s == 0 for p in Spatialiser(HeadLayout("helmet", sites)).place(point=near_a))


SCENE = {
    "name": "t",
    "actuators": {"helmet": {"type": "memory"}},
    "head": {"actuator": "helmet", "sites": {"crown": {"position": [0, 0, 0.13], "channel": 0}}},
    "effects": {"brick": {"actuator": "helmet", "inline": {"name": "b", "object": "concrete-brick",
                                                           "model": {"type": "kinetic-energy"}, "actuator": {"type": "memory"}}}},
}


@pytest.mark.parametrize("change, key, words", [
    ({"head": {"actuator": "nope", "sites": {}}}, "head.actuator", "name of a scene actuator"),
    ({"head": {"actuator": "helmet", "sites": {}}}, "head.sites", "non-empty mapping"),
    ({"head": {"actuator": "helmet", "where": 1, "sites": {}}}, "head", "unknown key 'where'"),
    ({"head": {"actuator": "helmet", "sites": {"a": {"position": [0, 0], "channel": 0}}}}, "head.sites.a.position", "[x, y, z]"),
    ({"head": {"actuator": "helmet", "sites": {"a": {"position": [0, 0, 0], "channel": 0}}}}, "head.sites.a.position", "centre"),
    ({"head": {"actuator": "helmet", "sites": {"a": {"position": [0, 0, 1], "channel": -1}}}}, "head.sites.a.channel", ">= 0"),
    ({"head": {"actuator": "helmet", "sites": {"a": {"position": [0, 0, 1], "channel": 0},
                                               "b": {"position": [0, 1, 0], "channel": 0}}}}, "head.sites.b.channel", "taken"),
    ({"head": {"actuator": "helmet", "sites": {"a": {"position": [0, 0, 1], "channel": 0},
                                               "b": {"position": [0, 0, 2], "channel": 1}}}}, "head.sites.b.position", "same way"),
    ({"head": {"actuator": "helmet", "wave_speed_mps": 0, "sites": {"a": {"position": [0, 0, 1], "channel": 0}}}},
     "head.wave_speed_mps", "speed > 0"),
])
def test_bad_head_sections_name_the_key(change, key, words):
    with pytest.raises(EffectError) as err:
        scene_from_mapping({**SCENE, **change}, source="s.yaml", base_dir=ROOT)
    assert err.value.key == key and words in str(err.value)


def test_a_head_that_no_effect_plays_on_is_refused():
    raw = yaml.safe_load(yaml.safe_dump(SCENE))
    raw["actuators"]["other"] = {"type": "memory"}
    raw["effects"]["brick"]["actuator"] = "other"
    with pytest.raises(EffectError, match="no effect plays on 'helmet'") as err:
        scene_from_mapping(raw, source="s.yaml", base_dir=ROOT)
    assert err.value.key == "head.actuator"


def test_an_entry_on_the_head_actuator_names_no_channel():
    raw = yaml.safe_load(yaml.safe_dump(SCENE))
    raw["effects"]["brick"]["channel"] = 0
    with pytest.raises(EffectError, match="its channels are the sites") as err:
        scene_from_mapping(raw, source="s.yaml", base_dir=ROOT)
    assert err.value.key == "effects.brick.channel"


def _render(scene, impacts) -> list[np.ndarray]:
    played = []
    with Engine(scene, device="memory", on_played=played.append) as engine:
        for kwargs in impacts:
            engine.impact(**kwargs)
    assert engine.stats()["rendered"] == len(impacts)
    return [np.atleast_2d(p.signal.samples) for p in played]


def test_one_actuator_on_the_crown_renders_bit_for_bit_as_without_a_head(tmp_path):
    """The paper's setup, three ways: the shipped scene, the same with points, and with a one-site head."""
    shipped = ROOT / "scenes" / "earthquake_room.yaml"
    raw = yaml.safe_load(shipped.read_text())
    raw["head"] = {"actuator": "helmet", "sites": {"crown": {"position": [0, 0, 0.13], "channel": 0}}}
    for entry in raw["effects"].values():
        entry["effect"] = str((shipped.parent / entry["effect"]).resolve())
    one_site = tmp_path / "crown.yaml"
    one_site.write_text(yaml.safe_dump(raw))
    plain = [dict(object=o, velocity=v, at=t) for t, (o, v) in enumerate(
        [("concrete-brick", 3.8), ("steel-plate", 2.43), ("wood-beam", 5.9), ("plastic-frame", 0.0), ("concrete-brick", 3.8)])]
    pointed = [dict(k, point=(0.05, -0.02, 0.11), normal=(0.1, 0.0, 1.0)) for k in plain]
    reference = _render(shipped, plain)
    for scene, impacts in ((shipped, pointed), (one_site, plain), (one_site, pointed)):
        got = _render(scene, impacts)
        assert len(got) == len(reference)
        for a, b in zip(reference, got):
            assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def test_the_helmet_plays_every_site_a_block_of_one_length_on_its_own_file(tmp_path):
    from hapticfx.actuators.files import read_wav

    wav = tmp_path / "helmet.wav"
    with Engine(HELMET, device=f"wav:{wav}") as engine:
        engine.impact("steel-plate", 4.2, at=0.5, point=(0.0, 0.0, R))
        engine.impact("wood-beam", 3.0, at=1.5, point=(R, 0.0, 0.065))
        engine.impact("concrete-brick", 2.5, at=2.5, channel=1)
        with pytest.raises(EffectError, match=r"head's channels \[0, 1, 2, 3\], not 7"):
            engine.impact("concrete-brick", 2.5, channel=7)
    files = sorted(tmp_path.glob("helmet-*.wav"))
    assert [f.name for f in files] == [f"helmet-actuators_helmet_{k}.wav" for k in range(4)]
    rate = read_wav(files[0])[0]
    signals = [read_wav(f)[1][0] for f in files]
    assert len({s.size for s in signals}) == 1
    # each file holds the impacts at their times, 1 s apart (the effects' profiles are of one length)
    n = signals[0].size - 2 * rate
    assert 0 < n <= rate
    peaks = np.array([[np.abs(s[i * rate:i * rate + n]).max() for s in signals] for i in range(3)])
    assert np.count_nonzero(peaks[0]) == 1 and peaks[0, 0] > 0   # the crown
    assert np.count_nonzero(peaks[1]) == 1 and peaks[1, 3] > 0   # the right ear's actuator
    assert np.count_nonzero(peaks[2]) == 1 and peaks[2, 1] > 0   # channel 1: the front
