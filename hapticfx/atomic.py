"""File paths and atomic writing: a file appears whole or not at all."""

from __future__ import annotations

import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .errors import HapticfxError


def user_path(text) -> Path:
    """``text`` as a path with ``~`` expanded; ``~name`` of an unknown user stays as written."""
    try:
        return Path(text).expanduser()
    except RuntimeError:  # no such user, or no home directory
        return Path(text)


def file_name_part(text: str, *, most: int = 64) -> str:
    """``text`` (an effect's name, say) made fit to go into a file name: letters, digits, ``.``, ``_`` and ``-``
    kept, every run of anything else (``/``, a NUL byte, a newline, a space) one ``-``, at most ``most`` characters;
    ``"-"`` where nothing is left."""
    return re.sub(r"[^\w.-]+", "-", text)[:most].strip("-") or "-"


def _nearest_existing(path: Path) -> Path:
    return next(p for p in (path, *path.parents) if p.exists())


def existing_folder(path: Path) -> Path:
    """The nearest of ``path`` and the folders above it that exists: a folder, else an error naming the file."""
    there = _nearest_existing(Path(path))
    if not there.is_dir():
        raise HapticfxError(f"{there}: not a folder")
    return there


def named(exc: OSError, path: Path) -> OSError:
    """``exc``; or, where it names a hidden temporary beside ``path`` (:func:`temporary_beside`) or a file in
    one, or names no file at all (a write to an open file: a full disk), the same error naming ``path``: the file
    the user asked for, not one they never saw."""
    hidden = os.path.abspath(path.parent / f".{path.name}.")
    names = [n for n in (exc.filename, exc.filename2) if n is not None]
    if exc.errno is not None and (not names or any(os.path.abspath(os.fsdecode(n)).startswith(hidden) for n in names)):
        return OSError(exc.errno, exc.strerror, str(path))  # errno picks the subclass (PermissionError, ...)
    return exc


@contextmanager
def naming(path: Path):
    """A block whose errors name ``path`` where they would name its hidden temporary (:func:`named`)."""
    try:
        yield
    except OSError as exc:
        mine = named(exc, path)
        if mine is exc:
            raise
        raise mine from exc


def temporary_beside(path: Path, *, folder: bool = False) -> Path:
    """A new hidden file (or folder) beside ``path``, to be written and then moved into place."""
    with naming(path):
        if folder:
            return Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
        os.close(fd)
        return Path(tmp)


def check_writable(folder: str | os.PathLike) -> None:
    """Raise :class:`OSError` (the system's reason) unless a file can be made in ``folder``, or, where it does
    not exist yet, in the nearest folder above it, where it would be made. The probe file is gone at once."""
    tempfile.TemporaryFile(dir=_nearest_existing(Path(folder))).close()


@contextmanager
def together(paths):
    """A block that writes each of ``paths`` (each whole, as :func:`atomic_path` does): should it fail, every one
    of them is as it was before the block, so that a set of files appears whole or not at all. A file a path held
    is kept aside, hidden beside it, until the block ends."""
    paths = [Path(p) for p in paths]
    new = [p for p in paths if not p.exists()]
    kept: dict[Path, Path] = {}
    try:
        for p in paths:
            if p.is_file():
                kept[p] = temporary_beside(p)
                with naming(p):
                    os.replace(p, kept[p])
        yield paths
    except BaseException:
        for p in new:
            if p.is_file():
                p.unlink()
        for p, aside in kept.items():
            os.replace(aside, p)
        raise
    for aside in kept.values():
        aside.unlink(missing_ok=True)


@contextmanager
def atomic_path(path: str | os.PathLike, *, make_parents: bool = False):
    """Yield a temporary path beside ``path``; move it into place only if the block succeeds."""
    path = Path(path)
    if path.is_dir():
        raise HapticfxError(f"{path}: is a directory, expected a file name")
    if make_parents:
        existing_folder(path.parent)
        path.parent.mkdir(parents=True, exist_ok=True)
    elif not path.parent.exists():
        raise HapticfxError(f"{path.parent}: directory does not exist")
    tmp = temporary_beside(path)
    umask = os.umask(0)
    os.umask(umask)
    try:
        with naming(path):
            yield tmp
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
            os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
