"""One participant's session: which screen comes next, playing a trial's stimuli, and taking answers.

The participant's page and the simulated participant both drive a session
through the same four calls (:meth:`Session.state`, :meth:`Session.play`,
:meth:`Session.answer`, :meth:`Session.proceed`). An answer is on disk before
:meth:`Session.answer` returns; a trial that has an answer is never shown again,
so an interrupted session resumes at the first trial without one. What the
page is told names no stimulus: the participant sees slots (target, A, B, ...)
only.
"""

from __future__ import annotations

import threading
import time

from .. import __version__
from ..errors import StudyError
from .results import ResultsLog, now_iso
from .schedule import Trial, build_schedule, schedule_sha256
from .spec import Study, Task


class AnswerRefused(StudyError):
    """The page sent something the session cannot take now (wrong trial, impacts not played, bad value)."""


def _public_questions(task: Task) -> list[dict]:
    return [{"id": q.id, "text": q.text, "low": q.low, "high": q.high,
             "anchors": [{"at": at, "label": label} for at, label in q.anchors]} for q in task.questions]


class Session:
    """The state of one participant's run of a study; thread-safe.

    ``player`` plays a :class:`~hapticfx.study.schedule.Slot` (see
    :class:`~hapticfx.study.player.StimulusPlayer`). ``enforce_breaks``: a break
    cannot be ended before its ``break_s`` (off for simulated participants).
    """

    def __init__(self, study: Study, participant: str, folder, player, *, study_text: bytes,
                 simulated: bool = False, enforce_breaks: bool = True):
        self.study = study
        self.participant = participant
        self.schedule: list[Trial] = build_schedule(study, participant)
        self.tasks = {t.name: t for t in study.tasks}
        self.player = player
        self.enforce_breaks = enforce_breaks
        header = {"participant": participant, "study": study.name, "study_sha256": study.sha256,
                  "schedule_sha256": schedule_sha256(self.schedule), "trials": len(self.schedule),
                  "seed": study.seed, "simulated": simulated, "hapticfx_version": __version__}
        self.log = ResultsLog.open(folder, study_text=study_text, participant=participant, header=header,
                                   tasks={t.name: (t.type, t.questions) for t in study.tasks})
        self.answered = set(self.log.answers())
        self.resumed = bool(self.answered)
        self.session_number = sum(1 for r in self.log.records if r.get("type") == "session")
        self._lock = threading.RLock()
        self._acknowledged: set[tuple[str, int]] = set()
        self._break_started: dict[int, float] = {}
        self._plays: dict[str, list[str]] = {}
        self._shown_at: str | None = None
        self._shown_mono = 0.0
        self._first_play_mono: float | None = None
        if self.done and not any(r.get("type") == "done" for r in self.log.records):
            self._finish()

    # --- where the participant is ----------------------------------------------------

    @property
    def position(self) -> int:
        """Index of the first trial without an answer (``len(schedule)`` when done)."""
        return next((t.index for t in self.schedule if t.index not in self.answered), len(self.schedule))

    @property
    def done(self) -> bool:
        return self.position >= len(self.schedule)

    def screen(self) -> str:
        """``instructions``, ``break``, ``trial`` or ``done``."""
        if self.done:
            return "done"
        trial = self.schedule[self.position]
        if (trial.first_of_task or self.resumed) and ("instructions", trial.index) not in self._acknowledged:
            return "instructions"
        if trial.break_before and ("break", trial.index) not in self._acknowledged:
            self._break_started.setdefault(trial.index, time.monotonic())
            return "break"
        if self._shown_at is None:
            self._shown_at, self._shown_mono = now_iso(), time.monotonic()
        return "trial"

    def state(self) -> dict:
        """What the page shows now (no stimulus names)."""
        with self._lock:
            screen = self.screen()
            main = [t for t in self.schedule if not t.practice]
            out = {"study": self.study.name, "participant": self.participant, "screen": screen,
                   "progress": {"answered": len(self.answered), "total": len(self.schedule),
                                "main_answered": sum(1 for t in main if t.index in self.answered), "main_total": len(main)}}
            if screen == "done":
                return out
            trial = self.schedule[self.position]
            task = self.tasks[trial.task]
            out["trial"] = {
                "index": trial.index, "task": task.name, "type": task.type, "practice": trial.practice,
                "number": trial.number, "of": sum(1 for t in self.schedule if t.task == task.name),
                "replay": task.replay, "gap_s": task.options.gap_s,
                "slots": [{"name": s.name, "impacts": len(s.velocities), "plays": len(self._plays.get(s.name, []))}
                          for s in trial.slots],
                "questions": _public_questions(task),
            }
            if screen == "instructions":
                out["instructions"] = task.options.instructions or f"Task: {task.name}."
                out["resumed"] = self.resumed
            if screen == "break":
                left = task.options.break_s - (time.monotonic() - self._break_started[trial.index])
                out["break_s_left"] = max(0.0, left) if self.enforce_breaks else 0.0
            return out

    # --- what the page can do -----------------------------------------------------------

    def _current(self, index: int, screen: str = "trial") -> Trial:
        if self.done:
            raise AnswerRefused("the session is complete")
        if index != self.position:
            raise AnswerRefused(f"trial {index} is not the current trial ({self.position})")
        if self.screen() != screen:
            raise AnswerRefused(f"the page shows {self.screen()!r}, not {screen!r}")
        return self.schedule[index]

    def proceed(self, index: int, screen: str) -> dict:
        """End the instructions or the break shown before trial ``index``."""
        with self._lock:
            if screen not in ("instructions", "break"):
                raise AnswerRefused(f"cannot proceed from {screen!r}")
            if index in self.answered or ((screen, index) in self._acknowledged and index == self.position):
                return self.state()  # a second click, or a reload that sent it again
            self._current(index, screen)
            if screen == "break" and self.enforce_breaks:
                left = self.tasks[self.schedule[index].task].options.break_s - (time.monotonic() - self._break_started[index])
                if left > 0:
                    raise AnswerRefused(f"the break lasts {left:.0f} s more")
            self._acknowledged.add((screen, index))
            if screen == "instructions":
                self.resumed = False
            return self.state()

    def play(self, index: int, slot_name: str) -> list:
        """Play one slot of the current trial; returns what reached the actuator (engine ``Playback`` records)."""
        with self._lock:
            trial = self._current(index)
            task = self.tasks[trial.task]
            slot = next((s for s in trial.slots if s.name == slot_name), None)
            if slot is None:
                raise AnswerRefused(f"trial {index} has no slot {slot_name!r}")
            if self._plays.get(slot_name) and not task.replay:
                raise AnswerRefused(f"this task plays each impact once; {slot_name!r} was played")
            if not task.replay:
                earlier = [s.name for s in trial.slots[: trial.slots.index(slot)] if not self._plays.get(s.name)]
                if earlier:
                    raise AnswerRefused(f"play {earlier[0]!r} first")
            played = self.player.play(slot, task.options.gap_s)
            if self._first_play_mono is None:
                self._first_play_mono = time.monotonic()
            self._plays.setdefault(slot_name, []).append(now_iso())
            return played

    def answer(self, index: int, response: dict) -> dict:
        """Record the answer to trial ``index`` (durably) and move on; sending it again changes nothing."""
        with self._lock:
            if index in self.answered:
                return {**self.state(), "duplicate": True}
            trial = self._current(index)
            task = self.tasks[trial.task]
            unplayed = [s.name for s in trial.slots if not self._plays.get(s.name)]
            if unplayed:
                raise AnswerRefused(f"play {', '.join(unplayed)} before answering")
            clean, chosen = self._validate(task, trial, response)
            answered_mono = time.monotonic()
            record = {
                "type": "answer", "participant": self.participant, "session": self.session_number,
                "trial": trial.index, "task": task.name, "kind": task.type, "cell": trial.cell,
                "role": task.roles.get(trial.cell), "practice": trial.practice, "number": trial.number,
                "repetition": trial.repetition, "velocity": trial.velocity, "match_by": task.match_by,
                "slots": [{"name": s.name, "stimulus": s.stimulus, "factors": self.study.stimuli[s.stimulus].factors,
                           "velocities": list(s.velocities), "drops": list(s.drops), "plays": self._plays[s.name]}
                          for s in trial.slots],
                "response": clean, "chosen_stimulus": chosen,
                "correct": None if trial.correct is None else clean["choice"] == trial.correct,
                "correct_slot": trial.correct, "shown_at": self._shown_at, "answered_at": now_iso(),
                "response_time_s": round(answered_mono - (self._first_play_mono or self._shown_mono), 6),
            }
            self.log.append(record)
            self.answered.add(index)
            self._plays, self._shown_at, self._first_play_mono = {}, None, None
            if self.done:
                self._finish()
            return self.state()

    @staticmethod
    def _validate(task: Task, trial: Trial, response) -> tuple[dict, str | None]:
        if not isinstance(response, dict):
            raise AnswerRefused(f"expected an answer object, got {response!r}")
        if task.type == "matching":
            choice = response.get("choice")
            names = {s.name: s.stimulus for s in trial.slots[1:]}
            if choice not in names:
                raise AnswerRefused(f"choose one of {', '.join(names)}, got {choice!r}")
            return {"choice": choice}, names[choice]
        ratings = response.get("ratings")
        if not isinstance(ratings, dict) or set(ratings) != {q.id for q in task.questions}:
            raise AnswerRefused(f"rate every question ({', '.join(q.id for q in task.questions)})")
        clean = {}
        for q in task.questions:
            v = ratings[q.id]
            if not q.holds(v):
                raise AnswerRefused(f"{q.id}: expected a number in [{q.low:g}, {q.high:g}], got {v!r}")
            clean[q.id] = float(v)
        return {"ratings": clean}, None

    def _finish(self) -> None:
        self.log.append({"type": "done", "at": now_iso(), "answers": len(self.answered)})

    def close(self) -> None:
        self.log.close()
