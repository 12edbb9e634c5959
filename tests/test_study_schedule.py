"""Schedules: reproducible from the seed, counterbalanced across participants, practice and breaks in place."""

from __future__ import annotations

from collections import Counter

import pytest

from hapticfx.errors import StudyError
from hapticfx.study.schedule import build_schedule, participant_number, williams
from hapticfx.study.spec import load_study
from study_files import small_study, write_study


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_williams_square_is_balanced(n):
    rows = williams(n)
    assert len(rows) == (n if n % 2 == 0 else 2 * n)
    for row in rows:
        assert sorted(row) == list(range(n))
    for position in range(n):  # each condition equally often at each position
        assert Counter(row[position] for row in rows) == Counter({c: len(rows) // n for c in range(n)})
    follows = Counter((a, b) for row in rows for a, b in zip(row, row[1:]))
    assert set(follows.values()) == {len(rows) // n} and len(follows) == n * (n - 1)


def test_participant_numbers():
    assert participant_number("P07") == 7 and participant_number("s12-b") == 12
    for bad in ("Pxx", "P 7", "", "../P1"):
        with pytest.raises(StudyError):
            participant_number(bad)


@pytest.fixture
def study(tmp_path):
    return load_study(write_study(tmp_path, small_study()))


def test_same_participant_same_schedule_others_differ(study):
    a, b = build_schedule(study, "P01"), build_schedule(study, "P01")
    assert [t.record() for t in a] == [t.record() for t in b]
    assert [t.record() for t in build_schedule(study, "P02")] != [t.record() for t in a]


def test_rating_conditions_follow_the_latin_square_across_participants(study):
    firsts = []
    for p in range(1, 5):
        main = [t for t in build_schedule(study, f"P{p:02d}") if t.task == "realism" and not t.practice]
        assert sorted(t.cell for t in main) == sorted(study.tasks[0].cells)
        assert all(t.slots[0].velocities in ((3.0, 4.1), (4.1, 3.0)) for t in main)  # every velocity, in a random order
        firsts.append(main[0].cell)
    assert sorted(firsts) == sorted(study.tasks[0].cells)  # 4 participants: every condition once in first place


def test_trials_practice_breaks_and_matching_answers(study):
    schedule = build_schedule(study, "P03")
    assert [t.index for t in schedule] == list(range(len(schedule)))
    realism = [t for t in schedule if t.task == "realism"]
    assert realism[0].practice and realism[0].first_of_task and not any(t.practice for t in realism[1:])
    assert [t.break_before for t in realism[1:]] == [False, False, True, False]  # break_every: 2
    matching = [t for t in schedule if t.task == "match"]
    assert len(matching) == 2 and matching[0].first_of_task
    for t in matching:
        target = study.stimuli[t.slots[0].stimulus].factors["object"]
        correct = next(s for s in t.slots if s.name == t.correct)
        assert study.stimuli[correct.stimulus].factors["object"] == target
    similarity = [t for t in schedule if t.task == "similarity"]
    upper = next(t for t in similarity if t.cell == "real-brick|real-brick")
    assert upper.slots[0].drops != upper.slots[1].drops  # two different recorded drops, as two real drops would be
    assert len(schedule) == 5 + 2 + 3
