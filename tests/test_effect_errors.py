"""Malformed effect files: each gives one exact message naming the file and key path."""

from __future__ import annotations

import subprocess
import sys

import pytest

from hapticfx.effect import check_effect, load_effect
from hapticfx.errors import EffectError

GOOD = """\
name: brick
object: concrete-brick
velocity_mps: 3.8
model:
  type: kinetic-energy
  pulse_ms: 30
actuator:
  type: memory
  gain: 0.8
"""

CASES = [
    ("unknown top-level key",
     GOOD + "colour: red\n",
     "{f}: (top level): unknown key 'colour'; allowed: name, description, object, velocity_mps, model, actuator"),
    ("unknown model key (misspelt)",
     GOOD.replace("pulse_ms: 30", "pulse_msec: 30"),
     "{f}: model: unknown key 'pulse_msec'; allowed: ke_max_j, pulse_ms, duration_ms, rate_hz, mass_kg"),
    ("wrong type",
     GOOD.replace("velocity_mps: 3.8", "velocity_mps: fast"),
     "{f}: velocity_mps: expected a number, got str 'fast'"),
    ("NaN velocity",
     GOOD.replace("velocity_mps: 3.8", "velocity_mps: .nan"),
     "{f}: velocity_mps: expected a finite number, got nan"),
    ("infinite velocity",
     GOOD.replace("velocity_mps: 3.8", "velocity_mps: .inf"),
     "{f}: velocity_mps: expected a finite number, got inf"),
    ("negative velocity",
     GOOD.replace("velocity_mps: 3.8", "velocity_mps: -1"),
     "{f}: velocity_mps: must be >= 0.0, got -1"),
    ("negative mass",
     GOOD.replace("object: concrete-brick", "object: {id: rock, mass_kg: -0.2}"),
     "{f}: object.mass_kg: must be >= 1e-06, got -0.2"),
    ("unknown model plugin",
     GOOD.replace("type: kinetic-energy", "type: quantum"),
     "{f}: model.type: unknown model 'quantum'; installed: "),
    ("unknown actuator plugin",
     GOOD.replace("type: memory", "type: rumble-pak"),
     "{f}: actuator.type: unknown actuator 'rumble-pak'; installed: "),
    ("a pulse shorter than a sample",
     GOOD.replace("pulse_ms: 30", "pulse_ms: 0.4"),
     "{f}: model.pulse_ms: pulse_ms 0.4 is under half a sample at rate_hz 1000: the pulse would be silent; "
     "give more than 0.5 ms"),
    ("a pulse that leaves no room for the silent first sample",
     GOOD.replace("pulse_ms: 30", "pulse_ms: 30\n  duration_ms: 30"),
     "{f}: model.duration_ms: pulse_ms 30 and the silent first sample (t = 0) do not fit in duration_ms 30 at "
     "rate_hz 1000: give duration_ms at least 31"),
    ("unknown actuator key lists the core keys too",
     GOOD.replace("gain: 0.8", "gian: 0.8"),
     "{f}: actuator: unknown key 'gian'; allowed: type, device, channel, gain, full_scale_g, limits, rate_hz, keep_mib"),
    ("unknown object key lists dimensions_mm too",
     GOOD.replace("object: concrete-brick", "object: {id: rock, mas_kg: 1}"),
     "{f}: object: unknown key 'mas_kg'; allowed: dimensions_mm, id, mass_kg, name, material"),
    ("python object tag",
     GOOD.replace("velocity_mps: 3.8", "velocity_mps: !!python/object/apply:os.system ['true']"),
     "{f}: invalid YAML: line 3, column 15: tag 'tag:yaml.org,2002:python/object/apply:os.system' is not allowed "
     "(these files hold plain mappings, lists, strings and numbers)"),
    ("duplicate key",
     GOOD + "velocity_mps: 4.0\n",
     "{f}: line 10: duplicate key 'velocity_mps' (first at line 3)"),
    ("missing model",
     "name: x\nobject: concrete-brick\nactuator: {type: memory}\n",
     "{f}: (top level): required key 'model' is missing"),
    ("model not a mapping",
     GOOD.replace("model:\n  type: kinetic-energy\n  pulse_ms: 30", "model: kinetic-energy"),
     "{f}: model: expected a mapping, got str 'kinetic-energy'"),
    ("gain above 1",
     GOOD.replace("gain: 0.8", "gain: 1.5"),
     "{f}: actuator.gain: must be <= 1.0, got 1.5"),
    ("limit raised above the hard limit",
     GOOD + "  limits: {rms: 0.9}\n",
     "{f}: actuator.limits: rms 0.9 would raise the actuator's hard limit 0.7; an effect can only make limits stricter"),
    ("bad YAML",
     "name: [unclosed\n",
     "{f}: invalid YAML: line 2, column 1: expected ',' or ']', but got '<stream end>'"),
    ("empty file", "", "{f}: the file is empty; an effect needs name, object, model and actuator"),
    ("wrong type in plugin params",
     GOOD.replace("pulse_ms: 30", "pulse_ms: [30]"),
     "{f}: model.pulse_ms: expected a number, got list [30]"),
    ("no mass for the kinetic-energy model",
     GOOD.replace("object: concrete-brick", "object: mystery-box"),
     "{f}: model: the kinetic-energy model needs a mass: describe the object with mass_kg, or set model.mass_kg"),
]


def _build(path):
    from hapticfx.pipeline import Pipeline

    Pipeline.from_effect(path, device="memory")


@pytest.mark.parametrize("label, text, message", CASES, ids=[c[0] for c in CASES])
def test_malformed_effect_message(write_effect, label, text, message):
    path = write_effect(text)
    with pytest.raises(EffectError) as err:
        _build(path)
    expected = message.format(f=path)
    if expected.endswith("installed: "):
        assert str(err.value).startswith(expected)
    else:
        assert str(err.value) == expected


def test_a_profile_shorter_than_the_fades_is_refused_when_the_effect_opens(write_effect):
    """A 2 ms pulse in 5 ms (or a 1 ms pulse in 2) rendered a profile at full amplitude that played as zeros."""
    from hapticfx.pipeline import Pipeline

    path = write_effect(GOOD.replace("pulse_ms: 30", "pulse_ms: 2\n  duration_ms: 5"))
    with pytest.raises(EffectError) as err:
        Pipeline.from_effect(path, device="memory").open()
    assert str(err.value) == (f"{path}: model: model 'kinetic-energy' renders 5 ms, shorter than the 12 ms the "
                              "actuator's signal fades in and out over: it would play (nearly) silent; give it at "
                              "least 12 ms (duration_ms)")


def test_a_scene_given_as_an_effect_and_an_effect_given_as_a_scene_say_what_they_are(write_effect):
    """They said `unknown key 'actuators'` and `unknown key 'object'`."""
    from pathlib import Path

    from hapticfx.engine import Engine

    root = Path(__file__).resolve().parents[1]
    with pytest.raises(EffectError, match=r"\(top level\): a scene \(effects and actuators, no model\), not an "
                                          r"effect: run it with `hapticfx serve FILE`"):
        load_effect(root / "scenes" / "earthquake_room.yaml")
    with pytest.raises(EffectError, match=r"\(top level\): an effect \(a model, no effects\), not a scene: play it "
                                          r"with `hapticfx play FILE`"):
        Engine(write_effect(GOOD))


def test_an_empty_object_id_and_no_effect_at_all_are_errors(write_effect):
    """`--object ""` played the effect's own object; `Pipeline.from_effect(None)` was a TypeError."""
    from hapticfx.pipeline import Pipeline

    pipeline = Pipeline.from_effect(write_effect(GOOD), device="memory")
    with pytest.raises(EffectError, match=r"object '': expected an object id \(none: the effect's 'concrete-brick'\)"):
        pipeline.render(object="")
    with pytest.raises(EffectError, match="expected an effect file's path or an Effect, got NoneType"):
        Pipeline.from_effect(None)


def test_missing_file(tmp_path):
    with pytest.raises(EffectError) as err:
        load_effect(tmp_path / "nope.yaml")
    assert str(err.value) == f"{tmp_path / 'nope.yaml'}: file not found"


def test_good_effect_passes(write_effect):
    plan = check_effect(load_effect(write_effect(GOOD)))
    assert plan.model_params.pulse_ms == 30.0


def test_numbers_in_exponent_form_are_numbers(write_effect):
    """YAML 1.1 reads 1e1 and 3.8e0 as text ('expected a number, got str'); JSON and YAML 1.2 read numbers."""
    effect = load_effect(write_effect(GOOD.replace("velocity_mps: 3.8", "velocity_mps: 3.8e0")
                                      .replace("pulse_ms: 30", "pulse_ms: 3e1")))
    assert effect.velocity_mps == 3.8 and check_effect(effect).model_params.pulse_ms == 30.0


def test_cli_user_error_is_one_line_exit_2(write_effect):
    path = write_effect(GOOD.replace("type: kinetic-energy", "type: quantum"))
    r = subprocess.run([sys.executable, "-m", "hapticfx", "play", str(path), "--device", "memory"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert r.stderr.startswith(f"hapticfx: error: {path}: model.type: unknown model 'quantum'")


def test_cli_debug_shows_traceback(write_effect):
    path = write_effect(GOOD.replace("type: kinetic-energy", "type: quantum"))
    r = subprocess.run([sys.executable, "-m", "hapticfx", "--debug", "play", str(path), "--device", "memory"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" in r.stderr


def test_validate_reports_each_file(write_effect):
    good = write_effect(GOOD, "good.yaml")
    bad = write_effect(GOOD.replace("gain: 0.8", "gain: 2"), "bad.yaml")
    r = subprocess.run([sys.executable, "-m", "hapticfx", "validate", str(good), str(bad)],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert f"ok: {good}" in r.stdout
    assert r.stderr.strip() == f"hapticfx: error: {bad}: actuator.gain: must be <= 1.0, got 2"


HOSTILE = {  # what a careless user or an attacker puts in an effect file -> the one line that says so
    "control character": ("name: \x06\n", "invalid YAML: unacceptable character #x0006"),
    "explicit int tag": ("name: !!int abc\n", "tag 'tag:yaml.org,2002:int' is not allowed"),
    "explicit bool tag": ("name: !!bool abc\n", "tag 'tag:yaml.org,2002:bool' is not allowed"),
    "timestamp tag": ("name: !!timestamp x\n", "tag 'tag:yaml.org,2002:timestamp' is not allowed"),
    "400-digit integer": (GOOD.replace("velocity_mps: 3.8", "velocity_mps: " + "9" * 400),
                          "velocity_mps: expected a number of ordinary size, got 9999999999...99999999999"),
    "list as a mapping key": ("? [a, b]\n: 1\n", "line 1: a mapping key must be a string or a number, got list"),
    "deep nesting": ("name: " + "[" * 200 + "]" * 200 + "\n", "nested deeper than 32 levels"),
    "alias bomb": ("a0: &a0 [x, x, x, x, x, x, x, x, x]\n"
                   + "".join(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]\n" for i in range(1, 9)) + "name: *a8\n",
                   "more than 64 aliases"),
    "huge list in a value": ("name: x\nobject: [" + ", ".join(["1"] * 5000) + "]\nmodel: {type: x}\nactuator: {type: x}\n",
                             "object: expected a mapping, got list [1, 1, 1, 1, ...]"),
}


@pytest.mark.parametrize("label", list(HOSTILE))
def test_hostile_effect_files_give_one_short_line(tmp_path, label):
    text, expected = HOSTILE[label]
    path = tmp_path / "e.yaml"
    path.write_text(text)
    with pytest.raises(EffectError) as info:
        load_effect(path)
    message = str(info.value)
    assert expected in message and "\n" not in message and len(message) < 300, message


@pytest.mark.parametrize("name, hint", [("impact.wav", "a WAV file goes to `hapticfx export`"), ("e.yaml", "")])
def test_a_binary_file_is_said_to_be_no_yaml(tmp_path, name, hint):
    path = tmp_path / name
    path.write_bytes(b"RIFF\x24\x08\x00\x00WAVEfmt \xff\xfe")
    with pytest.raises(EffectError) as info:
        load_effect(path)
    assert str(info.value) == (f"{path}: not a YAML text file (byte 16 is not UTF-8 text); expected an effect, scene or "
                               "study file" + (f"; {hint}" if hint else ""))


def test_long_paths_and_large_files_are_refused_in_one_line(tmp_path):
    with pytest.raises(EffectError, match="cannot read: File name too long"):
        load_effect(tmp_path / ("x" * 300 + ".yaml"))
    big = tmp_path / "big.yaml"
    big.write_text("# padding\n" * 200_000)
    with pytest.raises(EffectError, match=r"big.yaml: \d+ bytes; a YAML file here holds at most 1048576"):
        load_effect(big)


DD = """name: dd
object: concrete-brick
model: {type: data-driven, dataset: builtin:helmet-drops, interpolator: linear}
actuator: {type: memory}
"""


@pytest.mark.parametrize("change, expected", [
    (("interpolator: linear", "interpolator: spline"), "dd.yaml: model.interpolator: unknown interpolator 'spline'"),
    (("builtin:helmet-drops", "builtin:nope"), "dd.yaml: model: no built-in dataset 'nope'"),
    (("interpolator: linear}", "interpolator: linear, reducer: pca}"), "has banks for: dft321, max-min"),
    (("object: concrete-brick", "object: banana"), "dataset 'helmet-drops' has no object 'banana'"),
    (("interpolator: linear}", "interpolator: linear, interpolator_options: {grid: 1}}"),
     "model.interpolator_options: unknown key 'grid' for interpolator 'linear'; allowed: none"),
    (("interpolator: linear}", "interpolator: ensemble, interpolator_options: {trim: 2}}"),
     "interpolator_options.trim must be <= 0.5, got 2.0"),
    (("actuator: {type: memory}", "actuator: {type: memory, limits: {rms: 0.9}}"),
     "actuator.limits: rms 0.9 would raise the actuator's hard limit 0.7"),
    (("actuator: {type: memory}", "actuator: {type: memory, limits: {rms_window_s: 60}}"),
     "actuator.limits: rms_window_s 60.0 would lengthen the actuator's RMS window 0.05"),
])
def test_validate_runs_every_check_play_runs(tmp_path, change, expected):
    path = tmp_path / "dd.yaml"
    path.write_text(DD.replace(*change))
    r = subprocess.run([sys.executable, "-m", "hapticfx", "validate", str(path)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert expected in r.stderr, r.stderr
