"""A head of four actuators (scenes/helmet_4.yaml) on a 4-channel PulseAudio null sink, recorded back: each
impact reaches the channels the layout gives it, at the gains the spatialiser chose, within 1 dB."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SCENE = Path(__file__).resolve().parents[3] / "scenes" / "helmet_4.yaml"


@pytest.mark.soundserver
def test_a_helmet_of_four_plays_each_impact_on_its_channels_at_the_layouts_gains(soundserver):
    from hapticfx.scene import load_scene
    from hapticfx_soundcard.bench import helmet

    points = helmet.default_points(load_scene(SCENE).head)
    assert list(points) == ["crown", "front", "right", "between crown and front"]
    cap = helmet.capture(SCENE, list(points.values()), object="concrete-brick", velocity=2.6)
    assert len(cap.starts) == 4, cap.stats
    assert cap.stats["rendered"] == 4 and cap.stats["failed"] == 0
    for label, heard, want in zip(points, cap.heard_db, cap.expected_db):
        sounding = want > -200
        assert np.count_nonzero(sounding) == (2 if label.startswith("between") else 1)
        assert np.all(np.abs(heard[sounding] - want[sounding]) < 1.0), (label, heard, want)
        assert np.all(heard[~sounding] < -40.0), (label, heard)  # nothing leaks to the other actuators
    assert cap.expected_db[3][:2] == pytest.approx([-3.0103, -3.0103], abs=1e-3)  # halfway: -3 dB on each
    assert np.all(np.abs(cap.energy_db) < 1.0), cap.energy_db  # panning keeps the impact's energy


@pytest.mark.soundserver
def test_another_actuator_on_a_head_sites_channel_is_refused_not_limited_apart(soundserver, tmp_path):
    """The head's sites were never matched with the scene's other actuators: one on the crown's channel got a
    limiter of its own, and the two summed on that channel to 1.95 against a peak of 1."""
    from hapticfx.engine import Engine
    from hapticfx.errors import EffectError

    inline = "{name: e, object: steel-plate, model: {type: kinetic-energy}, actuator: {type: vibro-transducer}}"
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"""name: shared
actuators:
  helmet: {{type: vibro-transducer, device: default}}
  visor: {{type: vibro-transducer, device: default, channel: 0}}
head:
  actuator: helmet
  sites: {{crown: {{position: [0, 0, 0.13], channel: 0}}, back: {{position: [0, -0.1, 0.05], channel: 1}}}}
effects:
  plate: {{inline: {inline}, actuator: helmet}}
  beam: {{inline: {inline}, actuator: visor}}
""")
    with pytest.raises(EffectError, match=r"actuators\.visor plays into the output of the head's site 'crown'"):
        Engine(scene)
