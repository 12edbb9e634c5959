"""A participant's trials, in order: randomised from the study's seed and counterbalanced across participants.

The number in a participant id (``P07`` -> 7) picks the participant's row of a
balanced Latin square (Williams design: each condition comes first once, and
follows every other condition once, across a full set of rows) and seeds the
random draws. The same study file and participant id always give the same schedule.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import StudyError
from .spec import SLOT_NAMES, Study, Task

TARGET = "target"


@dataclass(frozen=True)
class Slot:
    """One stimulus a trial presents: where it sits on the page, and what plays."""

    name: str
    stimulus: str
    velocities: tuple[float, ...]
    drops: tuple[int | None, ...]


@dataclass(frozen=True)
class Trial:
    """One trial of a participant's schedule.

    ``index`` is its position in the whole schedule, ``number`` its position in
    its task (practice trials first). ``velocity`` is None when the trial plays
    every velocity of the task in a row. ``correct`` is the slot that matches
    the target (matching tasks).
    """

    index: int
    task: str
    type: str
    cell: str
    practice: bool
    number: int
    repetition: int
    velocity: float | None
    slots: tuple[Slot, ...]
    correct: str | None
    first_of_task: bool
    break_before: bool

    def record(self) -> dict:
        """The trial as plain JSON data."""
        return asdict(self)


def participant_number(participant: str) -> int:
    """The number in a participant id (``P07`` -> 7): it picks the Latin square row and seeds the order."""
    if not isinstance(participant, str) or not re.fullmatch(r"[A-Za-z0-9_-]{1,64}", participant):
        raise StudyError(f"participant id {participant!r}: use 1-64 letters, digits, '-' or '_' (e.g. P07)")
    found = re.search(r"(\d+)\D*$", participant)
    if not found:
        raise StudyError(f"participant id {participant!r} has no number; the number picks the counterbalanced order (e.g. P07)")
    return int(found.group(1))


def williams(n: int) -> list[list[int]]:
    """Rows of a balanced Latin square of ``n`` conditions (n rows for even n, 2n for odd n)."""
    first, lo, hi = [], 0, n - 1
    for k in range(n):
        if k % 2 == 0:
            first.append(lo)
            lo += 1
        else:
            first.append(hi)
            hi -= 1
    rows = [[(c + r) % n for c in first] for r in range(n)]
    if n % 2:
        rows += [row[::-1] for row in rows]
    return rows


def _row(n: int, number: int, rng_seed: list[int]) -> list[int]:
    """The participant's row of a Williams square over ``n`` items whose labels are shuffled once per study."""
    labels = np.random.default_rng(rng_seed).permutation(n)
    rows = williams(n)
    return [int(labels[i]) for i in rows[(number - 1) % len(rows)]]


class _Drops:
    """Draws which recorded drop plays, without repeating one within a trial while others are left."""

    def __init__(self, study: Study):
        self.study = study
        self._counts: dict[tuple[str, float], int] = {}

    def count(self, stimulus: str, velocity: float) -> int:
        key = (stimulus, velocity)
        if key not in self._counts:
            from ..models.recorded import RecordedDropModel
            from ..effect import check_effect

            s = self.study.stimuli[stimulus]
            model = RecordedDropModel(check_effect(s.effect).model_params, s.effect.context())
            velocities, accel = model.dataset.raw(s.object_id)
            for v, per_velocity in zip(velocities, accel):
                self._counts[(stimulus, float(v))] = int(per_velocity.shape[0])
        return self._counts[key]

    def draw(self, stimulus: str, velocity: float, used: set, rng) -> int | None:
        s = self.study.stimuli[stimulus]
        if not s.recorded or s.drops == "representative":
            return None
        n = self.count(stimulus, velocity)
        free = [d for d in range(n) if (stimulus, velocity, d) not in used] or list(range(n))
        d = int(free[rng.integers(len(free))])
        used.add((stimulus, velocity, d))
        return d


def _slots(task: Task, cell: str, velocities: tuple[float, ...], rng, drops: _Drops) -> tuple[tuple[Slot, ...], str | None]:
    stimuli = task.cells[cell]
    used: set = set()

    def slot(name, stimulus):
        vs = tuple(float(v) for v in (rng.permutation(velocities) if len(velocities) > 1 else velocities))
        return Slot(name, stimulus, vs, tuple(drops.draw(stimulus, v, used, rng) for v in vs))

    if task.type == "rating":
        return (slot("stimulus", stimuli[0]),), None
    if task.type == "matching":
        target, comparisons = stimuli[0], list(stimuli[1:])
        order = [comparisons[i] for i in rng.permutation(len(comparisons))]
        out = [slot(TARGET, target)] + [slot(SLOT_NAMES[i], c) for i, c in enumerate(order)]
        key = task.match_by
        want = drops.study.stimuli[target].factors[key]
        correct = next(s.name for s in out[1:] if drops.study.stimuli[s.stimulus].factors[key] == want)
        return tuple(out), correct
    pair = list(stimuli) if rng.random() < 0.5 else list(stimuli[::-1])
    return (slot("A", pair[0]), slot("B", pair[1])), None


def _task_trials(study: Study, task_index: int, number: int, drops: _Drops) -> list[tuple]:
    task = study.tasks[task_index]
    rng = np.random.default_rng([study.seed, number, task_index])
    sequence = task.type == "rating" and task.options.per_trial == "sequence"
    units = [(None, r) for r in range(task.options.repetitions)] if sequence else \
        [(v, r) for v in task.velocities for r in range(task.options.repetitions)]
    cells = list(task.cells)
    if task.options.order == "latin-square":
        main = []
        for c in _row(len(cells), number, [study.seed, task_index]):
            main += [(cells[c], units[i]) for i in rng.permutation(len(units))]
    else:
        every = [(c, u) for c in cells for u in units]
        main = [every[i] for i in rng.permutation(len(every))]
    every = [(c, u) for c in cells for u in units]
    n_practice = task.options.practice
    picks = rng.permutation(len(every))[:n_practice] if n_practice <= len(every) else rng.integers(len(every), size=n_practice)
    practice = [every[i] for i in picks]
    out = []
    for k, (cell, (velocity, rep)) in enumerate(practice + main):
        is_practice = k < n_practice
        vs = task.velocities if velocity is None else (velocity,)
        slots, correct = _slots(task, cell, vs, rng, drops)
        main_number = k - n_practice + 1
        every_n = task.options.break_every
        pause = not is_practice and every_n > 0 and main_number > 1 and (main_number - 1) % every_n == 0
        out.append((task.name, task.type, cell, is_practice, k + 1, rep, velocity, slots, correct, k == 0, pause))
    return out


def build_schedule(study: Study, participant: str) -> list[Trial]:
    """Every trial ``participant`` does, in the order they do them."""
    number = participant_number(participant)
    n = len(study.tasks)
    order = list(range(n)) if study.task_order == "fixed" else _row(n, number, [study.seed, n, 7])
    drops = _Drops(study)
    rows = [row for t in order for row in _task_trials(study, t, number, drops)]
    return [Trial(i, *row) for i, row in enumerate(rows)]


def schedule_sha256(schedule: list[Trial]) -> str:
    """A fingerprint of a schedule: a resumed session must continue the same one."""
    text = json.dumps([t.record() for t in schedule], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()
