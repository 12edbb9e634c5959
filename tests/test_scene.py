"""Scene files: validation errors name the file and key path; only referenced components load."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from hapticfx.errors import EffectError
from hapticfx.scene import load_scene

ROOT = Path(__file__).parents[1]

INLINE = "{name: b, object: concrete-brick, model: {type: kinetic-energy}, actuator: {type: memory}}"


def write(tmp_path: Path, text: str, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_minimal_scene_with_a_relative_effect_file(tmp_path):
    (tmp_path / "fx").mkdir()
    write(tmp_path / "fx", "name: brick\nobject: concrete-brick\nmodel: {type: kinetic-energy}\nactuator: {type: memory}\n", "brick.yaml")
    scene = load_scene(write(tmp_path, "name: s\neffects:\n  brick: fx/brick.yaml\n"))
    assert scene.objects == ["brick"] and scene.osc is None
    assert scene.entries["brick"].effect.source == str(tmp_path / "fx" / "brick.yaml")
    assert scene.engine.queue_size == 256


def test_shared_actuator_replaces_the_effects_own(tmp_path):
    scene = load_scene(write(tmp_path, f"""
name: s
actuators:
  helmet: {{type: memory, rate_hz: 8000, gain: 0.5, limits: {{peak: 0.8}}}}
effects:
  a: {{actuator: helmet, channel: 1, inline: {INLINE}}}
  b: {{actuator: helmet, inline: {{name: b, object: steel-plate, model: {{type: kinetic-energy}}, actuator: {{type: no-such-plugin}}}}}}
events:
  osc: {{port: 9123, rate_hz: 0}}
"""))
    a, b = scene.entries["a"], scene.entries["b"]
    assert a.effect.actuator.type == b.effect.actuator.type == "memory"
    assert a.effect.actuator.options == {"rate_hz": 8000}
    assert a.effect.actuator.channel == 1 and b.effect.actuator.channel is None
    assert a.effect.actuator.limits.peak == 0.8 and a.effect.actuator.gain == 0.5
    assert a.output == "actuators.helmet#1" and b.output == "actuators.helmet"
    assert scene.osc.port == 9123 and scene.osc.host == "127.0.0.1" and scene.osc.rate_hz == 0


def test_the_scene_actuators_own_channel_is_one_output_with_no_channel(tmp_path):
    """docs/embedding.md: entries on one scene actuator and channel share one opened actuator and one limiter,
    whether the channel is named (0, the actuator's first) or not; and so under a --device stand-in."""
    from hapticfx.engine import Engine

    path = write(tmp_path, f"""
name: s
actuators:
  helmet: {{type: memory}}
  pinned: {{type: memory, channel: 2}}
effects:
  a: {{actuator: helmet, channel: 0, inline: {INLINE}}}
  b: {{actuator: helmet, inline: {INLINE}}}
  c: {{actuator: pinned, channel: 2, inline: {INLINE}}}
  d: {{actuator: pinned, channel: 0, inline: {INLINE}}}
""")
    scene = load_scene(path)
    assert [scene.entries[k].output for k in "abcd"] == [
        "actuators.helmet", "actuators.helmet", "actuators.pinned", "actuators.pinned#0"]
    with Engine(path, device="memory") as engine:
        assert sorted(engine.stats()["outputs"]) == ["actuators.helmet", "actuators.pinned", "actuators.pinned#0"]


@pytest.mark.parametrize("body, key, words", [
    ("name: s\n", "(top level)", "required key 'effects'"),
    ("name: s\neffects: {}\n", "effects", "non-empty"),
    ("name: s\nshader: x\neffects: {a: x.yaml}\n", "(top level)", "unknown key 'shader'"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}, effect: x.yaml}}}}\n", "effects.a", "exactly one"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}, speed: 3}}}}\n", "effects.a", "unknown key 'speed'"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}, actuator: helmet}}}}\n", "effects.a.actuator", "unknown actuator 'helmet'"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}, channel: -1}}}}\n", "effects.a.channel", "channel number >= 0"),
    ("name: s\neffects: {a: {inline: {name: b, object: concrete-brick, model: {type: kinetic-energy}, actuator: {type: memory}, colour: red}}}\n",
     "effects.a.inline", "unknown key 'colour'"),
    ("name: s\neffects: {a: {inline: {name: b, object: concrete-brick, model: {type: kinetic-energy}, actuator: {type: memory, gain: 3}}}}\n",
     "effects.a.inline.actuator.gain", "must be <= 1"),
    (f"name: s\nactuators: {{h: {{type: memory, gain: 2}}}}\neffects: {{a: {{inline: {INLINE}}}}}\n", "actuators.h.gain", "must be <= 1"),
    (f"name: s\nactuators: {{h: {{gain: 0.5}}}}\neffects: {{a: {{inline: {INLINE}}}}}\n", "actuators.h", "required key 'type'"),
    (f"name: s\nactuators: {{h: {{type: memory, limits: {{peak: 2}}}}}}\neffects: {{a: {{inline: {INLINE}}}}}\n", "actuators.h.limits.peak", "must be <= 1"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}}}}}\nevents: {{osc: {{port: 70000}}}}\n", "events.osc.port", "must be <= 65535"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}}}}}\nevents: {{osc: {{hots: x}}}}\n", "events.osc", "unknown key 'hots'"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}}}}}\nevents: {{midi: {{}}}}\n", "events", "unknown event source 'midi'"),
    (f"name: s\neffects: {{a: {{inline: {INLINE}}}}}\nengine: {{queue_size: 0}}\n", "engine.queue_size", "must be >= 1"),
])
def test_errors_name_the_scene_file_and_key_path(tmp_path, body, key, words):
    path = write(tmp_path, body)
    with pytest.raises(EffectError) as err:
        load_scene(path)
    assert err.value.source == str(path)
    assert err.value.key == key
    assert words in str(err.value) and str(err.value).startswith(f"{path}: {key}: ")


@pytest.mark.parametrize("section, key, words", [
    ("{type: memory, gian: 0.5}", "actuators.h", "unknown key 'gian'; allowed: type, device, channel, gain,"),
    ("{type: nope}", "actuators.h.type", "unknown actuator 'nope'"),
])
def test_a_scene_actuators_plugin_error_names_the_scene_not_the_effect_it_carries(tmp_path, section, key, words):
    """The effect file's own actuator section is not where the fix goes: the scene's is."""
    write(tmp_path, "name: b\nobject: concrete-brick\nmodel: {type: kinetic-energy}\nactuator: {type: memory}\n",
          "brick.yaml")
    path = write(tmp_path, f"name: s\nactuators: {{h: {section}}}\neffects: {{a: {{effect: brick.yaml, actuator: h}}}}\n")
    from hapticfx.effect import check_effect

    with pytest.raises(EffectError) as err:
        check_effect(load_scene(path).entries["a"].effect)
    assert (err.value.source, err.value.key) == (str(path), key) and words in str(err.value)


def test_an_error_inside_a_referenced_effect_names_that_effect_file(tmp_path):
    bad = write(tmp_path, "name: b\nobject: concrete-brick\nmodel: {type: kinetic-energy}\nactuator: {type: memory, gain: 7}\n", "bad.yaml")
    with pytest.raises(EffectError) as err:
        load_scene(write(tmp_path, "name: s\neffects: {a: bad.yaml}\n"))
    assert err.value.source == str(bad) and err.value.key == "actuator.gain"


def test_missing_effect_file_and_unsafe_yaml(tmp_path):
    with pytest.raises(EffectError, match="missing.yaml: file not found"):
        load_scene(write(tmp_path, "name: s\neffects: {a: missing.yaml}\n"))
    with pytest.raises(EffectError, match="not allowed"):
        load_scene(write(tmp_path, "name: !!python/object/apply:os.system [echo hi]\neffects: {}\n"))


@pytest.mark.parametrize("scene", sorted((ROOT / "scenes").glob("*.yaml")), ids=lambda p: p.name)
def test_shipped_scenes_load(scene):
    assert load_scene(scene).objects


def test_a_physics_scene_loads_no_torch_sounddevice_or_serial(tmp_path):
    path = write(tmp_path, f"name: s\neffects: {{a: {{inline: {INLINE}}}}}\n")
    code = (
        "import sys; from hapticfx.engine import Engine\n"
        f"e = Engine({str(path)!r}); assert e.impact('a', 3.0); s = e.close(); assert s['rendered'] == 1, s\n"
        "bad = [m for m in ('torch', 'sounddevice', 'serial') if m in sys.modules]; assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
