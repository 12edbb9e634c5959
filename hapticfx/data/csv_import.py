"""Importing drop recordings from tidy CSV files into a dataset.

Format (one sample per row, header required, any row order between drops)::

    object,velocity_mps,drop,t_s,ax_g,ay_g,az_g
    wood-beam,3.96,0,0.000,0.012,-0.004,1.003

Rows of one drop share ``(object, velocity_mps, drop)`` and have increasing
``t_s`` at one uniform rate, the same for every drop in the import.
Accelerations are raw g (gravity included). Every bad row is reported with its
file and line number; nothing is written unless the whole import is good.
See docs/data.md.
"""

from __future__ import annotations

import csv
import hashlib
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from ..errors import DatasetError, one_line, preview
from ..objects import PAPER_OBJECTS, ObjectInfo, valid_object_id
from ..processing.preprocess import Preprocessing
from .build import ObjectRecordings, build_dataset

COLUMNS = ("object", "velocity_mps", "drop", "t_s", "ax_g", "ay_g", "az_g")
# Bounds that no real recording crosses: a number beyond them is a unit or typing mistake.
LIMITS = {"velocity_mps": (float("-inf"), 100.0), "t_s": (-1e6, 1e6), "ax_g": (-1e4, 1e4), "ay_g": (-1e4, 1e4),
          "az_g": (-1e4, 1e4)}
# Above twice the 20 Hz high-pass every drop goes through (a slower recording has no band above it), to 1 MHz.
RATE_HZ = (2 * Preprocessing().cutoff_hz, 1e6)
MIN_SAMPLES = 64
RATE_TOLERANCE = 0.01  # a sample interval may differ from its drop's median by 1 %
MAX_REPORTED = 3


@dataclass
class _Drop:
    file: str
    first_line: int
    lines: list[int] = field(default_factory=list)
    t: list[float] = field(default_factory=list)
    xyz: list[tuple[float, float, float]] = field(default_factory=list)


class _Problems:
    """Every problem found in the files: the count, and the first few in the one-line error."""

    def __init__(self):
        self.items: list[tuple[str, str]] = []
        self.count = 0

    def add(self, where: str, message: str) -> None:
        self.count += 1
        if len(self.items) < MAX_REPORTED:
            self.items.append((where, message))

    def raise_if_any(self) -> None:
        if not self.count:
            return
        files = {where.split(": line ")[0] for where, _ in self.items}
        source = files.pop() if len(files) == 1 else None
        shown = [f"{where[len(source) + 2:] if source else where}: {message}" for where, message in self.items]
        more = f"; ... and {self.count - len(self.items)} more" if self.count > len(self.items) else ""
        raise DatasetError(f"{self.count} problem(s): " + "; ".join(shown) + more, source=source)


def _number(text: str, column: str, where: str, problems: _Problems) -> float | None:
    if text.strip() == "":
        problems.add(where, f"{column} is empty (missing value)")
        return None
    try:
        value = float(text)
    except ValueError:
        problems.add(where, f"{column} {preview(text)} is not a number")
        return None
    if not math.isfinite(value):
        problems.add(where, f"{column} is {one_line(text, 20)} (expected a finite number)")
        return None
    lo, hi = LIMITS[column]
    if not lo <= value <= hi:
        problems.add(where, f"{column} {value:g} is " + (f"outside [{lo:g}, {hi:g}]" if math.isfinite(lo) else
                                                          f"above {hi:g}"))
        return None
    return value


def _read(file: Path, drops: dict, problems: _Problems) -> None:
    if file.is_dir():
        raise DatasetError(f"{file}: a folder; give the CSV files in it ({file / '*.csv'})")
    if not file.is_file():
        raise DatasetError(f"{file}: file not found")
    try:
        handle = file.open(newline="", encoding="utf-8-sig")  # a spreadsheet's byte-order mark is not a column
    except OSError as exc:
        raise DatasetError(f"{file}: cannot read ({exc})") from exc
    with handle:
        reader = csv.reader(handle)
        try:
            header = next((r for r in reader if any(c.strip() for c in r)), None)
            if header is None:
                raise DatasetError(f"{file}: empty file; expected the header {','.join(COLUMNS)}")
            header = [h.strip() for h in header]
            if tuple(header) != COLUMNS:
                missing = [c for c in COLUMNS if c not in header]
                extra = [c for c in header if c not in COLUMNS]
                detail = (f"missing {', '.join(missing)}" if missing else "") + \
                    ("; " if missing and extra else "") + (f"unexpected {', '.join(extra)}" if extra else "")
                raise DatasetError(
                    f"{file}: line {reader.line_num}: header must be exactly {','.join(COLUMNS)}"
                    + (f" ({detail})" if detail else " (columns out of order)")
                )
            for row in reader:
                where = f"{file}: line {reader.line_num}"
                if not row or all(not c.strip() for c in row):
                    continue
                if len(row) != len(COLUMNS):
                    problems.add(where, f"expected {len(COLUMNS)} fields ({','.join(COLUMNS)}), got {len(row)}"
                                 + (" (missing axis?)" if len(row) < len(COLUMNS) else ""))
                    continue
                obj = row[0].strip()
                if not valid_object_id(obj):
                    problems.add(where, f"object {preview(obj)} must be 1-64 letters, digits, '.', '_' or '-' "
                                        "(it names files in the dataset)")
                    continue
                v = _number(row[1], "velocity_mps", where, problems)
                drop_text = row[2].strip()
                if not drop_text.isdigit():
                    problems.add(where, f"drop {preview(row[2])} must be a non-negative integer")
                    drop = None
                else:
                    drop = int(drop_text)
                values = [_number(row[i], COLUMNS[i], where, problems) for i in range(3, 7)]
                if v is None or drop is None or any(x is None for x in values):
                    continue
                if v <= 0:
                    problems.add(where, f"velocity_mps {v} must be > 0")
                    continue
                key = (obj, v, drop)
                d = drops.get(key)
                if d is None:
                    d = drops[key] = _Drop(str(file), reader.line_num)
                if d.t and values[0] <= d.t[-1]:
                    problems.add(where, f"t_s {values[0]:g} is not after the previous sample's {d.t[-1]:g} "
                                        f"(object {obj}, {v:g} m/s, drop {drop}; time must increase)")
                    continue
                d.lines.append(reader.line_num)
                d.t.append(values[0])
                d.xyz.append(tuple(values[1:]))
        except csv.Error as exc:
            raise DatasetError(f"{file}: line {reader.line_num}: not valid CSV ({exc})") from exc
        except UnicodeDecodeError as exc:
            raise DatasetError(f"{file}: not UTF-8 text ({exc.reason} at byte {exc.start})") from exc


def _drop_rate(key, d: _Drop, problems: _Problems) -> float | None:
    where = f"{d.file}: line {d.first_line}"
    label = f"object {key[0]}, {key[1]:g} m/s, drop {key[2]}"
    if len(d.t) < MIN_SAMPLES:
        problems.add(where, f"{label} has {len(d.t)} samples; at least {MIN_SAMPLES} are needed")
        return None
    dt = np.diff(np.asarray(d.t))
    step = float(np.median(dt))
    off = np.flatnonzero(np.abs(dt - step) > RATE_TOLERANCE * step)
    if off.size:
        i = int(off[0])
        problems.add(f"{d.file}: line {d.lines[i + 1]}", f"{label}: sample interval {dt[i]:.6g} s differs from the "
                     f"drop's {step:.6g} s by more than {RATE_TOLERANCE:.0%} (uniform rate expected; mixed rates?)")
        return None
    if not RATE_HZ[0] < 1.0 / step <= RATE_HZ[1]:
        problems.add(where, f"{label}: sample interval {step:.6g} s is a rate of {1.0 / step:.6g} Hz; expected "
                     f"above {RATE_HZ[0]:g} Hz (twice the high-pass) to {RATE_HZ[1]:g} Hz (t_s in seconds?)")
        return None
    return 1.0 / step


def read_csv_recordings(files: Iterable[Path], *, masses: dict[str, float] | None = None) -> tuple[list[ObjectRecordings], float]:
    """Parse and check tidy CSV files; returns the recordings per object and the common rate in Hz."""
    problems = _Problems()
    drops: dict[tuple[str, float, int], _Drop] = {}
    files = [Path(f) for f in files]
    if not files:
        raise DatasetError("no CSV file given")
    for f in files:
        _read(f, drops, problems)
    problems.raise_if_any()
    if not drops:
        raise DatasetError(f"{', '.join(map(str, files))}: no data rows")
    rates = {key: _drop_rate(key, d, problems) for key, d in drops.items()}
    problems.raise_if_any()
    first_key = next(iter(drops))
    rate = float(f"{rates[first_key]:.9g}")  # t_s is printed rounded; 999.9999999999991 Hz is 1 kHz
    for key, r in rates.items():
        if abs(r - rate) > RATE_TOLERANCE * rate:
            d = drops[key]
            problems.add(f"{d.file}: line {d.first_line}", f"object {key[0]}, {key[1]:g} m/s, drop {key[2]} is at "
                         f"{r:.6g} Hz but object {first_key[0]}, {first_key[1]:g} m/s, drop {first_key[2]} is at "
                         f"{rate:.6g} Hz (mixed rates: resample before importing)")
    problems.raise_if_any()

    by_object: dict[str, dict[float, dict[int, _Drop]]] = defaultdict(lambda: defaultdict(dict))
    for (obj, v, drop), d in drops.items():
        by_object[obj][v][drop] = d
    recordings = []
    for obj, per_v in by_object.items():
        info = _object_info(obj, masses or {}, next(iter(next(iter(per_v.values())).values())))
        velocities = sorted(per_v)
        counts = {v: len(per_v[v]) for v in velocities}
        lengths = {len(d.t) for v in velocities for d in per_v[v].values()}
        if len(set(counts.values())) != 1:
            few = min(velocities, key=lambda v: counts[v])
            d = min(per_v[few].values(), key=lambda d: d.first_line)
            raise DatasetError(f"{d.file}: line {d.first_line}: object {obj}: every velocity needs the same number of drops, got "
                               + ", ".join(f"{v:g} m/s: {n}" for v, n in counts.items()))
        if len(lengths) != 1:
            short = min((len(d.t), d.file, d.first_line, v, k) for v in velocities for k, d in per_v[v].items())
            raise DatasetError(f"{short[1]}: line {short[2]}: object {obj}, {short[3]:g} m/s, drop {short[4]} has "
                               f"{short[0]} samples but other drops have {max(lengths)}; every drop of an object "
                               "needs the same number of samples")
        accel = np.array([[per_v[v][k].xyz for k in sorted(per_v[v])] for v in velocities], dtype=np.float64)
        recordings.append(ObjectRecordings(info, np.array(velocities), accel))
    return recordings, float(rate)


def _object_info(obj: str, masses: dict[str, float], d: _Drop) -> ObjectInfo:
    if obj in masses:
        base = PAPER_OBJECTS.get(obj)
        if base:
            return ObjectInfo(obj, base.name, float(masses[obj]), base.dimensions_mm, base.material)
        return ObjectInfo(obj, obj, float(masses[obj]))
    if obj in PAPER_OBJECTS:
        return PAPER_OBJECTS[obj]
    raise DatasetError(f"{d.file}: line {d.first_line}: object {obj!r} is not built in "
                       f"({', '.join(PAPER_OBJECTS)}); give its mass with --mass {obj}=KG")


def _sha256(file: Path) -> str:
    h = hashlib.sha256()
    with file.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def import_csv(files: Iterable[Path], out: Path, *, name: str | None = None, sensor: dict | None = None,
               masses: dict[str, float] | None = None, overwrite: bool = False,
               progress: Callable[[str], None] | None = None) -> Path:
    """Import tidy CSV files into a new dataset at ``out`` (see :func:`build_dataset`)."""
    files = [Path(f) for f in files]
    recordings, rate = read_csv_recordings(files, masses=masses)
    provenance = {"source": "csv", "files": [{"name": f.name, "sha256": _sha256(f)} for f in files]}
    return build_dataset(Path(out), recordings, name=name or Path(out).name, rate_hz=rate,
                         sensor=sensor or {"model": "unknown"}, provenance=provenance,
                         overwrite=overwrite, progress=progress)
