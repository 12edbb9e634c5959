"""Results on disk: one append-only JSON-lines file per participant, each answer flushed and fsynced.

A results folder holds ``study.yaml`` (the study file the answers belong to)
and ``<participant>.jsonl``. Each line is one record: ``session`` when a run
starts or resumes, ``answer`` for every answer as it is given, ``done`` when
the last trial is answered. A line cut short by a crash was never acknowledged
to the participant's page; it is dropped (and said so in the next ``session``
record) before anything new is appended.
"""

from __future__ import annotations

import json
import os
from datetime import datetime, timezone
from pathlib import Path

from ..atomic import atomic_path
from ..errors import StudyError, preview
from .spec import Question, task_questions

STUDY_COPY = "study.yaml"
RECORD_TYPES = ("session", "answer", "done")
# What the analysis reads of an answer record, and the type it must be (None: any value, null included).
ANSWER_KEYS = {"trial": int, "session": int, "task": str, "kind": str, "cell": str, "practice": bool, "slots": list,
               "response": dict, "role": None, "number": None, "repetition": None, "velocity": None, "correct": None,
               "chosen_stimulus": None, "match_by": None, "response_time_s": None, "answered_at": None}
Tasks = dict[str, tuple[str, tuple[Question, ...]]]  # task name -> (type, questions)


def now_iso() -> str:
    """Wall-clock time, UTC, to the microsecond."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _answer_problem(r: dict, tasks: Tasks) -> str | None:
    """What is wrong with answer record ``r`` for a study with ``tasks``; None if nothing is."""
    for key, kind in ANSWER_KEYS.items():
        if key not in r:
            return f"required key {key!r} is missing"
        if kind is not None and (not isinstance(r[key], kind) or isinstance(r[key], bool) != (kind is bool)):
            return f"{key}: expected {kind.__name__}, got {preview(r[key])}"
    if tasks.get(r["task"], ("",))[0] != r["kind"]:
        known = ", ".join(f"{name} ({kind})" for name, (kind, _) in tasks.items())
        return f"task: expected one of the study's tasks {known}, got {preview(r['task'])} ({preview(r['kind'])})"
    slots = r["slots"]
    if not slots or not all(isinstance(s, dict) and isinstance(s.get("name"), str) and isinstance(s.get("stimulus"), str)
                            and isinstance(s.get("factors"), dict) for s in slots):
        return f"slots: expected a list of slots with name, stimulus and factors, got {preview(slots)}"
    stimuli = [s["stimulus"] for s in slots]  # a similarity pair is played in either order
    cells = dict.fromkeys(("|".join(stimuli), "|".join(stimuli[::-1])) if r["kind"] == "similarity" else stimuli[:1])
    if r["cell"] not in cells:
        return f"cell: expected {' or '.join(map(repr, cells))} (its slots' stimuli), got {preview(r['cell'])}"
    response, questions = r["response"], tasks[r["task"]][1]
    if r["kind"] == "matching":
        chosen = next((s for s in slots[1:] if s["name"] == response.get("choice")), None)
        if chosen is None or chosen["stimulus"] != r["chosen_stimulus"] or not isinstance(r["correct"], bool):
            return (f"response: expected the choice of a comparison ({', '.join(s['name'] for s in slots[1:])}), its "
                    f"chosen_stimulus and whether it is correct, got {preview(response)}")
        if not all(r["match_by"] in s["factors"] for s in (slots[0], chosen)):
            return f"match_by: expected a factor of the target and the chosen stimulus, got {preview(r['match_by'])}"
        return None
    ratings = response.get("ratings")
    if not isinstance(ratings, dict) or set(ratings) != {q.id for q in questions}:
        return f"response.ratings: expected a rating of {', '.join(q.id for q in questions)}, got {preview(ratings)}"
    bad = next((q for q in questions if not q.holds(ratings[q.id])), None)
    if bad is not None:
        return f"response.ratings.{bad.id}: expected a number in [{bad.low:g}, {bad.high:g}], got {preview(ratings[bad.id])}"
    return None


def read_records(path: Path, tasks: Tasks) -> tuple[list[dict], int]:
    """The complete records of a results file, and how many bytes of a torn last line follow them.

    Each line must be a JSON object of a known type, and each answer one to a task of ``tasks`` (the study's)
    with its ratings on the question's scale.
    """
    data = path.read_bytes()
    end = data.rfind(b"\n") + 1
    records = []
    for n, line in enumerate(data[:end].split(b"\n")[:-1], 1):
        try:
            record = json.loads(line)
        except (ValueError, RecursionError) as exc:  # not JSON, not UTF-8, or nested past the parser's depth
            reason = exc.msg if isinstance(exc, json.JSONDecodeError) else "not UTF-8" if isinstance(exc, UnicodeError) else exc
            raise StudyError(f"line {n} is not JSON ({reason}); the file was edited by hand?", source=str(path)) from None
        if not isinstance(record, dict) or record.get("type") not in RECORD_TYPES:
            raise StudyError(f"expected a record object with type {', '.join(RECORD_TYPES)}, got {preview(record)}",
                             source=str(path), key=f"line {n}")
        problem = _answer_problem(record, tasks) if record["type"] == "answer" else None
        if problem:
            raise StudyError(problem, source=str(path), key=f"line {n}")
        records.append(record)
    return records, len(data) - end


class ResultsLog:
    """The results file of one participant, opened for appending. Use :meth:`open`."""

    def __init__(self, path: Path, records: list[dict]):
        self.path = path
        self.records = records
        self._file = open(path, "ab", buffering=0)

    @classmethod
    def open(cls, folder: Path, *, study_text: bytes, participant: str, header: dict, tasks: Tasks) -> "ResultsLog":
        """Open (or create) ``folder/<participant>.jsonl`` and append a ``session`` record.

        ``header`` identifies the study and the schedule; resuming with a
        different one is an error, so answers are never mixed across versions.
        ``tasks`` are the study's (see :func:`read_records`).
        """
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        copy = folder / STUDY_COPY
        if copy.exists():
            if copy.read_bytes() != study_text:
                raise StudyError(f"holds results of another study file ({copy} differs); choose another --out folder",
                                 source=str(folder))
        else:
            with atomic_path(copy) as tmp:
                tmp.write_bytes(study_text)
        path = folder / f"{participant}.jsonl"
        records, torn = read_records(path, tasks) if path.exists() else ([], 0)
        sessions = [r for r in records if r.get("type") == "session"]
        for key in ("study_sha256", "schedule_sha256", "participant"):
            if sessions and sessions[0].get(key) != header.get(key):
                raise StudyError(f"was started with a different {key.replace('_', ' ')}; this run cannot resume it",
                                 source=str(path))
        if torn:
            with open(path, "r+b") as f:
                f.truncate(path.stat().st_size - torn)
                os.fsync(f.fileno())
        created = not path.exists()
        log = cls(path, records)
        if created:
            _fsync_dir(folder)
        log.append({"type": "session", "at": now_iso(), "resumed": bool(sessions), "discarded_bytes": torn, **header})
        return log

    def append(self, record: dict) -> None:
        """Write one record durably: it is on disk when this returns."""
        line = (json.dumps(record, sort_keys=True, allow_nan=False) + "\n").encode()
        view = memoryview(line)
        while view:
            view = view[self._file.write(view):]
        os.fsync(self._file.fileno())
        self.records.append(record)

    def answers(self) -> dict[int, dict]:
        """The answer records so far, by trial index."""
        return {r["trial"]: r for r in self.records if r.get("type") == "answer"}

    def close(self) -> None:
        self._file.close()


def load_folder(folder: Path) -> dict[str, list[dict]]:
    """Every participant's records in a results folder (participant id -> records)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise StudyError("not a results folder (it does not exist)" if not folder.exists() else "not a folder",
                         source=str(folder))
    files = sorted(folder.glob("*.jsonl"))
    if not files:
        raise StudyError("holds no results (no <participant>.jsonl files)", source=str(folder))
    copy = folder / STUDY_COPY
    if not copy.is_file():
        raise StudyError(f"holds no {STUDY_COPY}, the copy of the study file its answers are checked against",
                         source=str(folder))
    tasks = task_questions(copy)
    return {f.stem: read_records(f, tasks)[0] for f in files}
