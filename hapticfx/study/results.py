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

STUDY_COPY = "study.yaml"
RECORD_TYPES = ("session", "answer", "done")


def now_iso() -> str:
    """Wall-clock time, UTC, to the microsecond."""
    return datetime.now(timezone.utc).isoformat(timespec="microseconds")


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def read_records(path: Path) -> tuple[list[dict], int]:
    """The complete records of a results file (each line a JSON object of a known type), and how many bytes of a
    torn last line follow them."""
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
            raise StudyError(f"line {n}: expected a record object with type {', '.join(RECORD_TYPES)}, got {preview(record)}",
                             source=str(path))
        records.append(record)
    return records, len(data) - end


class ResultsLog:
    """The results file of one participant, opened for appending. Use :meth:`open`."""

    def __init__(self, path: Path, records: list[dict]):
        self.path = path
        self.records = records
        self._file = open(path, "ab", buffering=0)

    @classmethod
    def open(cls, folder: Path, *, study_text: bytes, participant: str, header: dict) -> "ResultsLog":
        """Open (or create) ``folder/<participant>.jsonl`` and append a ``session`` record.

        ``header`` identifies the study and the schedule; resuming with a
        different one is an error, so answers are never mixed across versions.
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
        records, torn = read_records(path) if path.exists() else ([], 0)
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
    return {f.stem: read_records(f)[0] for f in files}
