"""The on-disk dataset format (version 1) and its lazy reader and atomic writer.

A dataset is a directory::

    dataset.json                 metadata: rate, window length, sensor, provenance, objects
    raw/<object>.npz             velocities_mps (V,), accel_g (V, D, N, 3): every drop, 3 axes, g
    banks/<reducer>/<object>.npz velocities_mps (V,), profiles_g (V, N), representative (V,) int

Optional metadata written by :func:`hapticfx.data.build.build_dataset`:
``raw_rate_hz`` (rate of ``raw/``), ``preprocessing`` (the chain's parameters),
``sensor``, ``provenance`` and, per object, ``representative`` (``chosen``,
``automatic`` and manual ``overrides``). See docs/data.md.

Arrays are plain ``.npz`` read with ``allow_pickle=False``. Reading is lazy: a
scene that uses one object reads only that object's files. ``builtin:NAME``
names a dataset shipped inside the package (``hapticfx/datasets/NAME``).
"""

from __future__ import annotations

import json
import os
import shutil
import threading
import struct
import tokenize
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..atomic import existing_folder, named, naming, temporary_beside, user_path
from ..errors import DatasetError, HapticfxError, SignalError, one_line, preview
from ..objects import ObjectInfo, valid_object_id
from .bank import ProfileBank

FORMAT = "hapticfx-dataset"
VERSION = 1
BUILTIN_PREFIX = "builtin:"
BUILTIN_DIR = Path(__file__).resolve().parent.parent / "datasets"
# What reading a damaged .npz can raise, from the file system to the zip and .npy layers
# (zipfile raises RuntimeError for a member whose header says it is encrypted).
UNREADABLE = (OSError, ValueError, EOFError, KeyError, IndexError, TypeError, zipfile.BadZipFile, zlib.error,
              struct.error, NotImplementedError, SyntaxError, tokenize.TokenError, MemoryError, RuntimeError)


def unreadable(exc: BaseException) -> str:
    """Why an ``.npz`` could not be read, in a few words: numpy takes bytes that are not a zip (a damaged file)
    for pickled data and says how to load it unsafely, which is not advice to give about a damaged file."""
    if isinstance(exc, ValueError) and "pickled" in str(exc):
        return "not an .npz archive of plain arrays"
    return one_line(str(exc), 80)


def resolve_dataset_path(ref: str | os.PathLike, *, relative_to: Path | None = None) -> Path:
    """The directory a dataset reference names (``builtin:NAME`` or a path)."""
    text = str(ref)
    if text.startswith(BUILTIN_PREFIX):
        name = text[len(BUILTIN_PREFIX):]
        path = BUILTIN_DIR / name
        if not valid_object_id(name) or not (path / "dataset.json").is_file():
            known = sorted(p.name for p in BUILTIN_DIR.glob("*") if (p / "dataset.json").is_file()) if BUILTIN_DIR.is_dir() else []
            raise DatasetError(f"no built-in dataset {preview(name)}; built-in: {', '.join(known) or 'none'}")
        return path
    path = user_path(text)
    if not path.is_absolute() and relative_to is not None:
        path = relative_to / path
    return path


@dataclass
class Dataset:
    """A dataset directory, read lazily. Use :func:`open_dataset`."""

    path: Path
    meta: dict
    _banks: dict = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @property
    def name(self) -> str:
        return self.meta.get("name", self.path.name)

    @property
    def rate_hz(self) -> float:
        return float(self.meta["rate_hz"])

    @property
    def n_samples(self) -> int:
        return int(self.meta["n_samples"])

    @property
    def objects(self) -> list[str]:
        return list(self.meta["objects"])

    def object_info(self, object_id: str) -> ObjectInfo:
        o = self._object_meta(object_id)
        return ObjectInfo(
            object_id,
            o.get("name", object_id),
            float(o["mass_kg"]),
            tuple(o.get("dimensions_mm", (0.0, 0.0, 0.0))),
            o.get("material", "unknown"),
        )

    def reducers(self) -> list[str]:
        banks = self.path / "banks"
        return sorted(p.name for p in banks.iterdir() if p.is_dir()) if banks.is_dir() else []

    def _object_meta(self, object_id: str) -> dict:
        try:
            return self.meta["objects"][object_id]
        except KeyError:
            raise DatasetError(
                f"dataset {self.name!r} has no object {object_id!r}; it has: {', '.join(self.objects)}"
            ) from None

    def bank(self, object_id: str, reducer: str) -> ProfileBank:
        """The representative-profile bank of one object under one reducer (cached)."""
        self._object_meta(object_id)
        if not valid_object_id(reducer):  # it names a folder
            raise DatasetError(f"{preview(reducer)} is not a reducer name; dataset {self.name!r} has banks for: "
                               f"{', '.join(self.reducers()) or 'none'}")
        key = (object_id, reducer)
        with self._lock:
            if key not in self._banks:
                file = self.path / "banks" / reducer / f"{object_id}.npz"
                if not file.is_file():
                    raise DatasetError(
                        f"{file}: missing; dataset {self.name!r} has banks for: {', '.join(self.reducers()) or 'none'}"
                    )
                arrays = load_npz(file, ("velocities_mps", "profiles_g"))
                self._agree(file, object_id, arrays["velocities_mps"], representative=arrays.get("representative"))
                length = arrays["profiles_g"].shape[-1] if arrays["profiles_g"].ndim else None
                if length != self.n_samples:
                    raise DatasetError(f"profiles of {length} samples where dataset.json's n_samples is "
                                       f"{self.n_samples}", source=str(file), key="profiles_g")
                try:
                    self._banks[key] = ProfileBank(
                        object_id, reducer, self.rate_hz, arrays["velocities_mps"], arrays["profiles_g"]
                    )
                except Exception as exc:
                    raise DatasetError(f"{file}: corrupt bank: {exc}") from exc
            return self._banks[key]

    @property
    def raw_rate_hz(self) -> float:
        """Sample rate of the raw recordings (the bank rate when not recorded separately)."""
        return float(self.meta.get("raw_rate_hz", self.meta["rate_hz"]))

    def representatives(self, object_id: str) -> dict:
        """The representative drop per velocity: ``chosen``, ``automatic``, ``overrides``."""
        rep = self._object_meta(object_id).get("representative")
        if rep is None:
            raise DatasetError(f"dataset {self.name!r}: object {object_id!r} records no representative drops")
        return rep

    def windows(self, object_id: str) -> tuple[np.ndarray, np.ndarray]:
        """All drops of one object preprocessed as the banks were: ``velocities (V,)``, ``(V, D, n_samples, 3)``."""
        from ..processing.preprocess import Preprocessing, preprocess

        velocities, accel = self.raw(object_id)
        params = Preprocessing.from_dict(self.meta.get("preprocessing", {}))
        try:
            return velocities, preprocess(accel, self.raw_rate_hz, params=params)
        except SignalError as exc:
            raise DatasetError(f"raw/{object_id}.npz: {exc}", source=str(self.path / "dataset.json"),
                               key="preprocessing") from None

    def raw(self, object_id: str) -> tuple[np.ndarray, np.ndarray]:
        """All drops of one object: ``velocities (V,)`` and ``accel_g (V, D, N, 3)``."""
        self._object_meta(object_id)
        file = self.path / "raw" / f"{object_id}.npz"
        arrays = load_npz(file, ("velocities_mps", "accel_g"))
        acc = arrays["accel_g"]
        if acc.ndim != 4 or acc.shape[-1] != 3 or acc.shape[0] != arrays["velocities_mps"].shape[0]:
            raise DatasetError(f"{file}: accel_g must have shape (V, drops, N, 3), got {acc.shape}")
        self._agree(file, object_id, arrays["velocities_mps"], drops=acc.shape[1])
        return arrays["velocities_mps"].astype(np.float64), acc.astype(np.float64)

    def _agree(self, file: Path, object_id: str, velocities: np.ndarray, *, drops: int | None = None,
               representative: np.ndarray | None = None) -> None:
        """Refuse arrays of ``file`` that disagree with what dataset.json says of the object: its velocities,
        its number of drops a velocity, its representative drops."""
        o = self._object_meta(object_id)
        listed, chosen = o.get("velocities_mps"), o.get("representative", {}).get("chosen")
        for key, got, meta_key, expected in (("velocities_mps", velocities, "velocities_mps", listed),
                                             ("representative", representative, "representative.chosen", chosen)):
            got = None if got is None else np.atleast_1d(got).tolist()
            if got is None or expected is None or got == expected:
                continue
            i = next((i for i, (a, b) in enumerate(zip(got, expected)) if a != b), None)
            raise DatasetError((f"{len(got)} values" if i is None else f"{preview(got[i])} at index {i}")
                               + f" where dataset.json's objects.{object_id}.{meta_key} has "
                               + (f"{len(expected)}" if i is None else preview(expected[i])), source=str(file), key=key)
        if drops is not None and (o.get("n_drops", drops) != drops or max(chosen or [0]) >= drops):
            raise DatasetError(f"{drops} drops a velocity where dataset.json has n_drops {o.get('n_drops')} and "
                               f"representatives {preview(chosen)}", source=str(file), key="accel_g")


def load_npz(file: Path, required: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Read an ``.npz`` without pickle; a missing or corrupt file is a :class:`DatasetError`."""
    if not file.is_file():
        raise DatasetError(f"{file}: file not found")
    try:
        with np.load(file, allow_pickle=False) as z:
            missing = [k for k in required if k not in z.files]
            if missing:
                raise DatasetError(f"{file}: missing array(s) {', '.join(missing)}; has {', '.join(z.files)}")
            return {k: z[k] for k in z.files}
    except DatasetError:
        raise
    except UNREADABLE as exc:
        raise DatasetError(f"{file}: corrupt or unreadable ({unreadable(exc)})") from None


def read_versioned_json(file: Path, *, format: str, version: int, error: type[HapticfxError]) -> dict:
    """A JSON metadata file that names its ``format`` and ``version``; anything else raises ``error``."""
    try:
        meta = json.loads(Path(file).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise error(f"{file}: corrupt metadata ({exc})") from exc
    if not isinstance(meta, dict) or meta.get("format") != format:
        raise error(f"{file}: not a {format} file")
    if meta.get("version") != version:
        raise error(f"{file}: format version {meta.get('version')!r}; this hapticfx reads version {version}")
    return meta


def open_dataset(ref: str | os.PathLike, *, relative_to: Path | None = None) -> Dataset:
    """Open a dataset by path or ``builtin:NAME``; reads only its metadata (checked here)."""
    path = resolve_dataset_path(ref, relative_to=relative_to)
    meta_file = path / "dataset.json"
    try:
        found = meta_file.is_file()
    except OSError as exc:  # a path the system refuses (too long, a loop)
        raise DatasetError(f"{preview(str(path))}: cannot open ({exc.strerror})") from None
    if not found:
        raise DatasetError(f"{path}: not a hapticfx dataset (no dataset.json)")
    meta = read_versioned_json(meta_file, format=FORMAT, version=VERSION, error=DatasetError)
    _check_meta(meta, meta_file)
    return Dataset(path, meta)


def _check_meta(meta: dict, where: Path) -> None:
    """The metadata every reader relies on: rates, length, objects with a mass, preprocessing."""
    from ..processing.preprocess import Preprocessing

    def number(key: str, value, lo: float, hi: float, integer: bool = False) -> None:
        ok = isinstance(value, int) if integer else isinstance(value, (int, float))
        if isinstance(value, bool) or not ok or not lo <= value <= hi:  # NaN fails the range test
            raise DatasetError(f"expected {'an integer' if integer else 'a number'} in [{lo:g}, {hi:g}], got "
                               f"{preview(value)}", source=str(where), key=key)

    for key in ("rate_hz", "n_samples", "objects"):
        if key not in meta:
            raise DatasetError(f"missing key {key!r}", source=str(where))
    number("rate_hz", meta["rate_hz"], 1.0, 1e6)
    number("raw_rate_hz", meta.get("raw_rate_hz", meta["rate_hz"]), 1.0, 1e6)
    number("n_samples", meta["n_samples"], 1, 1_000_000, integer=True)
    objects = meta["objects"]
    if not isinstance(objects, dict) or not all(valid_object_id(o) and isinstance(v, dict) for o, v in objects.items()):
        raise DatasetError("expected a mapping of object ids to their descriptions", source=str(where), key="objects")
    for obj, info in objects.items():
        number(f"objects.{obj}.mass_kg", info.get("mass_kg"), 1e-6, 1e4)
        if "n_drops" in info:
            number(f"objects.{obj}.n_drops", info["n_drops"], 1, 1_000_000, integer=True)
        _check_drops_meta(info, f"objects.{obj}", where)
    prep = meta.get("preprocessing", {})
    if not isinstance(prep, dict):
        raise DatasetError("expected a mapping", source=str(where), key="preprocessing")
    try:
        Preprocessing.from_dict(prep)
    except HapticfxError as exc:
        raise DatasetError(str(exc), source=str(where), key="preprocessing") from None


def check_output(out: Path, *, overwrite: bool) -> None:
    """Refuse, before any work, a dataset folder ``out`` that exists (unless ``overwrite``) or that could not
    be written where it goes (its folder, or the nearest one there is when that is to be made)."""
    out = Path(out)
    if out.exists() and not overwrite:
        raise DatasetError(f"{out}: already exists (use --force to replace it)")
    try:
        temporary_beside(existing_folder(out.parent) / out.name, folder=True).rmdir()
    except OSError as exc:
        raise DatasetError(f"{out}: cannot be written ({exc.strerror})") from None


def _check_drops_meta(info: dict, key: str, where: Path) -> None:
    """What one object's entry says of its drops: its velocities and the representative drop of each."""
    def fail(sub: str, expected: str, value) -> None:
        raise DatasetError(f"expected {expected}, got {preview(value)}", source=str(where), key=f"{key}.{sub}")

    def real(v) -> bool:  # NaN fails the range test; a bound keeps a huge integer out of float arithmetic
        return isinstance(v, (int, float)) and not isinstance(v, bool) and -1e9 < v < 1e9

    vs, drops = info.get("velocities_mps"), info.get("n_drops")
    if vs is not None and not (isinstance(vs, list) and vs and all(real(v) and v > 0 for v in vs)
                               and all(a < b for a, b in zip(vs, vs[1:]))):
        fail("velocities_mps", "increasing velocities in m/s, each > 0", vs)
    rep = info.get("representative")
    if rep is None:
        return
    if not isinstance(rep, dict):
        fail("representative", "a mapping", rep)

    def index(i) -> bool:
        return isinstance(i, int) and not isinstance(i, bool) and 0 <= i < (drops or float("inf"))

    span = f"[0, {drops - 1}]" if drops else ">= 0"
    each = f"each of the {len(vs)} velocities" if vs else "each velocity"
    for part in ("chosen", "automatic"):
        got = rep.get(part)
        if (part == "chosen" or got is not None) and not (
                isinstance(got, list) and (vs is None or len(got) == len(vs)) and all(index(i) for i in got)):
            fail(f"representative.{part}", f"a drop index in {span} for {each}", got)
    overrides = rep.get("overrides", [])
    if not isinstance(overrides, list) or not all(
            isinstance(o, dict) and index(o.get("drop")) and real(o.get("velocity_mps"))
            and any(abs(o["velocity_mps"] - v) <= 1e-6 for v in (vs or [o["velocity_mps"]])) for o in overrides):
        fail("representative.overrides", f"a list of {{velocity_mps: a recorded velocity, drop: an index in {span}}}",
             overrides)


class DatasetWriter:
    """Writes a dataset into a temporary directory and moves it into place on success.

    Use as a context manager: if the block raises, nothing is left behind.
    """

    def __init__(self, out: Path, *, name: str, rate_hz: float, n_samples: int, overwrite: bool = False, **meta):
        self.out = Path(out)
        self.overwrite = overwrite
        self.meta = {
            "format": FORMAT, "version": VERSION, "name": name,
            "rate_hz": float(rate_hz), "n_samples": int(n_samples), "objects": {}, **meta,
        }
        self.tmp: Path | None = None
        self.made: list[Path] = []  # the folders made for it, deepest first: removed again if it fails

    def __enter__(self) -> "DatasetWriter":
        check_output(self.out, overwrite=self.overwrite)
        self.made = [p for p in self.out.parents if not p.exists()]
        self.out.parent.mkdir(parents=True, exist_ok=True)
        self.tmp = temporary_beside(self.out, folder=True)
        # mkdtemp makes the directory private (0700); a dataset is as readable as any new directory.
        umask = os.umask(0o022)
        os.umask(umask)
        os.chmod(self.tmp, 0o777 & ~umask)
        return self

    def add_object(self, info: ObjectInfo, **extra) -> None:
        if not valid_object_id(info.id):
            raise DatasetError(f"object id {preview(info.id)} must be 1-64 letters, digits, '.', '_' or '-' "
                               "(it names files in the dataset)")
        self.meta["objects"][info.id] = {
            "name": info.name, "mass_kg": info.mass_kg,
            "dimensions_mm": list(info.dimensions_mm), "material": info.material, **extra,
        }

    def write_raw(self, object_id: str, velocities: np.ndarray, accel_g: np.ndarray) -> None:
        self._save(self.tmp / "raw" / f"{object_id}.npz", velocities_mps=np.asarray(velocities, np.float64),
                   accel_g=np.asarray(accel_g, np.float32))

    def write_bank(self, reducer: str, object_id: str, velocities, profiles, representative=None) -> None:
        v = np.asarray(velocities, np.float64)
        rep = np.zeros(v.shape, np.int64) if representative is None else np.asarray(representative, np.int64)
        self._save(self.tmp / "banks" / reducer / f"{object_id}.npz", velocities_mps=v,
                   profiles_g=np.asarray(profiles, np.float64), representative=rep)

    @staticmethod
    def _save(file: Path, **arrays) -> None:
        file.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(file, **arrays)

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            for folder in self.made:
                try:
                    folder.rmdir()
                except OSError:  # something else is in it now
                    break
            if isinstance(exc, OSError) and named(exc, self.out) is not exc:
                raise named(exc, self.out) from exc
            return False
        with naming(self.out):
            (self.tmp / "dataset.json").write_text(json.dumps(self.meta, indent=2, sort_keys=True) + "\n")
            if self.out.exists():
                backup = self.out.with_name(f".{self.out.name}.old")
                shutil.rmtree(backup, ignore_errors=True)
                os.replace(self.out, backup)
                os.replace(self.tmp, self.out)
                shutil.rmtree(backup, ignore_errors=True)
            else:
                os.replace(self.tmp, self.out)
        return False
