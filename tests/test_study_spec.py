"""Study files: what they accept, and one-line errors naming the file, the key and what was expected."""

from __future__ import annotations

import pytest

from hapticfx.errors import HapticfxError
from hapticfx.study.spec import load_study
from study_files import small_study, write_study


def test_small_study_loads(tmp_path):
    study = load_study(write_study(tmp_path, small_study()))
    assert list(study.stimuli) == ["phys-brick", "phys-steel", "dd-brick", "dd-steel", "real-brick", "real-steel"]
    assert study.stimuli["real-brick"].recorded and study.stimuli["real-brick"].drops == "random"
    assert study.stimuli["dd-brick"].effect.model.type == "data-driven"
    rating, matching, similarity = study.tasks
    assert rating.questions[0].anchors == ((0.0, "not at all"), (100.0, "completely"))
    assert matching.cells["dd-brick"] == ("dd-brick", "real-brick", "real-steel") and matching.replay
    assert similarity.roles == {"dd-brick|real-brick": "test", "real-brick|real-brick": "upper",
                                "real-brick|real-steel": "lower"}
    assert not similarity.replay


def _broken(change):
    study = small_study()
    change(study)
    return study


CASES = [
    (lambda s: s.update(colour="red"), "(top level): unknown key 'colour'; allowed: name, description, seed"),
    (lambda s: s.pop("tasks"), "(top level): required key 'tasks' is missing"),
    (lambda s: s.update(seed=-1), "seed: expected an integer >= 0, got -1"),
    (lambda s: s["stimuli"]["dd-brick"].update(actuator="vest"),
     "stimuli.dd-brick.actuator: unknown actuator 'vest'; the study's actuators: helmet"),
    (lambda s: s["stimuli"]["dd-brick"].update(recorded={"object": "concrete-brick"}),
     "stimuli.dd-brick: give exactly one of 'effect' (an effect file) or 'recorded'"),
    (lambda s: s["stimuli"]["real-brick"]["recorded"].update(object="anvil"),
     "stimuli.real-brick.recorded: dataset 'helmet-drops' has no object 'anvil'"),
    (lambda s: s["stimuli"]["real-brick"]["recorded"].update(drop="third"),
     "stimuli.real-brick.recorded.drop: expected 'random' or 'representative', got 'third'"),
    (lambda s: s["stimuli"]["dd-brick"].update(effect="nowhere.yaml"), "stimuli.dd-brick.effect: "),
    (lambda s: s["tasks"][0].update(type="ranking"), "tasks[0].type: expected type rating, matching or similarity, got 'ranking'"),
    (lambda s: s["tasks"][0].update(order="alphabetical"), "tasks[0].order: expected one of 'random', 'latin-square'"),
    (lambda s: s["tasks"][0].update(stimuli=["dd-brick", "dd-anvil"]),
     "tasks[0].stimuli[1]: unknown stimulus 'dd-anvil'; the study's stimuli: phys-brick"),
    (lambda s: s["tasks"][0].update(repetitions=0), "tasks[0].repetitions: must be >= 1, got 0"),
    (lambda s: s["tasks"][0]["questions"][0].update(anchors=["one"]),
     "tasks[0].questions[0].anchors: expected [label at low, label at high]"),
    (lambda s: s["tasks"][0]["questions"][0].pop("text"), "tasks[0].questions[0]: required key 'text' is missing"),
    (lambda s: s["tasks"][1].update(match_by="colour"), "tasks[1].match_by: stimulus 'dd-brick' has no factor 'colour'"),
    (lambda s: s["tasks"][1].update(comparisons=["real-brick", "dd-brick"]),
     "tasks[1].targets: target 'dd-brick' must match exactly one comparison by 'object', matches ['real-brick', 'dd-brick']"),
    (lambda s: s["tasks"][1].update(velocities=[3.8]),
     "tasks[1].velocities: recorded stimulus 'real-brick' has no drops at 3.8 m/s; recorded: 2.42, 2.8"),
    (lambda s: s["tasks"][2].update(upper=[["real-brick"]]), "tasks[2].upper[0]: expected [stimulus, stimulus], got ['real-brick']"),
    (lambda s: s["tasks"][2].update(lower=[["dd-brick", "real-brick"]]), "tasks[2]: pair 'dd-brick|real-brick' is listed twice"),
    (lambda s: s.update(simulate={"noise_sd": -1}), "simulate.noise_sd: must be >= 0.0, got -1"),
    (lambda s: s.update(simulate={"effects": [{"shift": "big"}]}), "simulate.effects[0].shift: expected a number of scale points"),
    (lambda s: s.update(simulate={"effects": [{"shift": 5, "question": "realsim"}]}),
     "simulate.effects[0].question: unknown question 'realsim'; the study asks realism, match, similarity"),
    (lambda s: s.update(simulate={"effects": [{"shift": 5, "task": "match", "question": "realism"}]}),
     "simulate.effects[0].question: unknown question 'realism'; task match asks match"),
    (lambda s: s.update(simulate={"effects": [{"shift": 5, "task": ["realism"]}]}),
     "simulate.effects[0].task: unknown task ['realism']; the study's tasks: realism, match, similarity"),
    (lambda s: s.update(simulate={"effects": [{"shift": 5, "when": {"colour": "red"}}]}),
     "simulate.effects[0].when: no stimulus has a factor 'colour'; the stimuli's factors: method, object"),
    (lambda s: s.update(simulate={"effects": [{"shift": 5, "when": {"method": "physics", "object": "wood"}}]}),
     "simulate.effects[0].when.object: no stimulus has object 'wood'; its levels: brick, steel"),
]


@pytest.mark.parametrize("change, expected", CASES)
def test_errors_name_file_key_and_what_was_expected(tmp_path, change, expected):
    path = write_study(tmp_path, _broken(change))
    with pytest.raises(HapticfxError) as err:
        load_study(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and message.count(str(path)) == 1 and expected in message, message
    assert "\n" not in message


def test_an_effect_files_own_error_names_both_files(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nobject: concrete-brick\nmodel: {type: kinetic-energy, pulse: 3}\nactuator: {type: memory}\n")
    study = small_study()
    study["stimuli"]["phys-brick"]["effect"] = str(bad)
    path = write_study(tmp_path, study)
    with pytest.raises(HapticfxError, match=rf"^{path}: stimuli.phys-brick.effect: {bad}: model: unknown key 'pulse'"):
        load_study(path)


def test_a_study_actuators_plugin_error_names_the_study_not_the_stimulus_effect(tmp_path):
    study = small_study()
    study["actuators"]["helmet"]["gian"] = 0.5
    path = write_study(tmp_path, study)
    with pytest.raises(HapticfxError, match=rf"^{path}: actuators.helmet: unknown key 'gian'; allowed: type, "):
        load_study(path)


def test_duplicate_keys_and_tags_are_refused(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("name: a\nname: b\n")
    with pytest.raises(HapticfxError, match="duplicate key 'name'"):
        load_study(path)
    path.write_text("name: !!python/object:os.system x\n")
    with pytest.raises(HapticfxError, match="is not allowed"):
        load_study(path)


def test_shipped_example_studies_load():
    from pathlib import Path

    pytest.importorskip("hapticfx_soundcard")
    pytest.importorskip("hapticfx_solenoid")
    paths = sorted((Path(__file__).resolve().parents[1] / "studies").glob("*.yaml"))
    assert [p.name for p in paths] == ["paper_study1.yaml", "paper_study2.yaml"]
    study1, study2 = (load_study(p) for p in paths)
    assert len(study1.tasks[0].cells) == 20  # 12 physics (3 actuators) + 8 data-driven (2 actuators)
    assert [t.type for t in study2.tasks] == ["matching"] * 5 + ["similarity"]
