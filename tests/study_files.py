"""Study files shared by the study tests: the paper's effects on a memory actuator (no hardware needed)."""

from __future__ import annotations

import random
from pathlib import Path

import yaml

EFFECTS = Path(__file__).resolve().parents[1] / "effects"


def small_study(**task_changes) -> dict:
    """Two objects, physics vs data-driven vs recorded drops; a rating, a matching and a similarity task."""
    def effect(name):
        return str(EFFECTS / name)

    study = {
        "name": "small",
        "seed": 11,
        "actuators": {"helmet": {"type": "memory"}},
        "stimuli": {
            "phys-brick": {"effect": effect("falling_brick_kinetic.yaml"), "factors": {"method": "physics", "object": "brick"}},
            "phys-steel": {"effect": effect("falling_steel_plate_kinetic.yaml"), "factors": {"method": "physics", "object": "steel"}},
            "dd-brick": {"effect": effect("falling_brick_linear.yaml"), "factors": {"method": "data-driven", "object": "brick"}},
            "dd-steel": {"effect": effect("falling_steel_plate_linear.yaml"), "factors": {"method": "data-driven", "object": "steel"}},
            "real-brick": {"recorded": {"object": "concrete-brick"}, "factors": {"method": "real", "object": "brick"}},
            "real-steel": {"recorded": {"object": "steel-plate"}, "factors": {"method": "real", "object": "steel"}},
        },
        "tasks": [
            {"name": "realism", "type": "rating", "stimuli": ["phys-brick", "phys-steel", "dd-brick", "dd-steel"],
             "velocities": [3.0, 4.1], "per_trial": "sequence", "order": "latin-square", "practice": 1, "break_every": 2,
             "gap_s": 0.0, "instructions": "Rate each impact.",
             "questions": [{"id": "realism", "text": "How realistic was the impact?", "anchors": ["not at all", "completely"]}]},
            {"name": "match", "type": "matching", "targets": ["dd-brick", "dd-steel"],
             "comparisons": ["real-brick", "real-steel"], "match_by": "object", "velocities": [3.7],
             "question": "Which impact feels like the target?"},
            {"name": "similarity", "type": "similarity", "pairs": [["dd-brick", "real-brick"]],
             "upper": [["real-brick", "real-brick"]], "lower": [["real-brick", "real-steel"]], "velocities": [3.7],
             "question": {"text": "How similar were the two impacts?", "anchors": ["completely different", "identical"]}},
        ],
    }
    for i, changes in task_changes.items():
        study["tasks"][int(i[1:])].update(changes)
    return study


def write_study(folder: Path, study: dict, name: str = "study.yaml") -> Path:
    path = folder / name
    path.write_text(yaml.safe_dump(study, sort_keys=False))
    return path


def damaged(path: Path, how: str) -> str:
    """Damage a results file as a disk or a hand edit could; returns what the error must say about it."""
    lines = path.read_bytes().count(b"\n")
    if how == "random bytes":
        path.write_bytes(random.Random(7).randbytes(4096))
        return "line 1 is not JSON ("
    path.write_bytes(path.read_bytes() + b"[1,2]\n")
    return f"line {lines + 1}: expected a record object with type session, answer, done, got [1, 2]"

