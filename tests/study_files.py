"""Study files shared by the study tests: the paper's effects on a memory actuator (no hardware needed)."""

from __future__ import annotations

import json
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


RATING = "response.ratings.realism: expected a number in [0, 100], got "
ANSWER_DAMAGE = {  # how: (the kind of answer changed, the change, what the error says after "line N: ")
    "a bogus cell": ("rating", lambda r: r.update(cell="bogus"), "cell: expected {cell!r} (its slots' stimuli), got 'bogus'"),
    "no response": ("rating", lambda r: r.pop("response"), "required key 'response' is missing"),
    "a rating 'high'": ("rating", lambda r: r["response"]["ratings"].update(realism="high"), RATING + "'high'"),
    "a rating of nan": ("rating", lambda r: r["response"]["ratings"].update(realism=float("nan")), RATING + "nan"),
    "a rating of inf": ("rating", lambda r: r["response"]["ratings"].update(realism=float("inf")), RATING + "inf"),
    "a rating of 1e9": ("rating", lambda r: r["response"]["ratings"].update(realism=1e9), RATING + "1000000000.0"),
    "a bogus choice": ("matching", lambda r: r["response"].update(choice="Z"), "response: expected the choice of a comparison (A, B)"),
}


def damaged(path: Path, how: str) -> str:
    """Damage a results file as a disk or a hand edit could; returns what the error must say about it."""
    lines = path.read_bytes().split(b"\n")  # the last is empty
    if how == "random bytes":
        path.write_bytes(random.Random(7).randbytes(4096))
        return "line 1 is not JSON ("
    if how == "a list line":
        path.write_bytes(path.read_bytes() + b"[1,2]\n")
        return f"line {len(lines)}: expected a record object with type session, answer, done, got [1, 2]"
    kind, change, says = ANSWER_DAMAGE[how]
    n, record = next((n, r) for n, r in enumerate(map(json.loads, lines[:-1]), 1) if r.get("kind") == kind)
    expected = f"line {n}: " + says.format(**record)
    change(record)
    lines[n - 1] = json.dumps(record).encode()
    path.write_bytes(b"\n".join(lines))
    return expected
