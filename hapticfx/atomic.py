"""File paths and atomic writing: a file appears whole or not at all."""

from __future__ import annotations

import os
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


@contextmanager
def atomic_path(path: str | os.PathLike, *, make_parents: bool = False):
    """Yield a temporary path beside ``path``; move it into place only if the block succeeds."""
    path = Path(path)
    if path.is_dir():
        raise HapticfxError(f"{path}: is a directory, expected a file name")
    if make_parents:
        path.parent.mkdir(parents=True, exist_ok=True)
    elif not path.parent.exists():
        raise HapticfxError(f"{path.parent}: directory does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
