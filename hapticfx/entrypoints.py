"""The ``hapticfx`` entry points of the installed distributions, read once and kept until what is installed changes.

Finding them through :mod:`importlib.metadata` costs every start 40-60 ms on a 2-core machine: the module
and the e-mail parser it imports, then a walk over every distribution's metadata. What it finds depends
only on installed files, so it is kept in ``entry-points.json`` of the user cache folder
(:func:`hapticfx.caches.cache_root`) beside a fingerprint of those files: every ``*.dist-info`` and
``*.egg-info`` folder on ``sys.path``, in order, with the size and time of its ``entry_points.txt``.
Installing, removing, upgrading or editing a distribution changes the fingerprint, and the next start reads
the metadata again; the four most recently used fingerprints keep their lists. Reading the fingerprint is a
directory listing per ``sys.path`` entry. An edit that keeps both the size and the time of an
``entry_points.txt`` is not seen; deleting the cache file is always safe.
"""

from __future__ import annotations

import importlib
import json
import os
import stat
import sys
from dataclasses import dataclass

from .atomic import atomic_path
from .caches import cache_root
from .errors import HapticfxError

GROUP = "hapticfx"
CACHE_NAME = "entry-points.json"
# Lists kept, one per fingerprint, most recently used first: the console script and ``python -m hapticfx`` in a source
# tree (whose ``*.egg-info`` is then on ``sys.path``) see different ones, and neither should evict the other.
KEPT = 4


@dataclass(frozen=True)
class EntryPoint:
    """One entry point of group ``hapticfx`` and the distribution that declares it."""

    name: str
    value: str
    distribution: str
    version: str

    def load(self):
        """The object the entry point names (``module`` or ``module:attribute.attribute``), as importlib loads it."""
        module, _, attrs = self.value.split("[", 1)[0].strip().partition(":")
        obj = importlib.import_module(module.strip())
        for attr in filter(None, attrs.strip().split(".")):
            obj = getattr(obj, attr)
        return obj


@dataclass(frozen=True)
class Installed:
    """What the registry needs of the installed distributions."""

    hapticfx_version: str
    entry_points: tuple[EntryPoint, ...]


def fingerprint() -> list:
    """Every distribution's metadata folder on ``sys.path`` in order, with its entry_points.txt's size and
    time (or ``None`` without one); a file on ``sys.path`` (a zip) with its own size and time."""
    marks: list = []
    for entry in sys.path:
        path = entry or os.getcwd()
        try:
            st = os.stat(path)
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode):
            marks.append([path, st.st_size, st.st_mtime_ns])
            continue
        try:
            with os.scandir(path) as it:
                names = sorted(e.name for e in it if e.name.endswith((".dist-info", ".egg-info")))
        except OSError:
            continue
        for name in names:
            try:
                ep = os.stat(os.path.join(path, name, "entry_points.txt"))
                marks.append([path, name, ep.st_size, ep.st_mtime_ns])
            except OSError:
                marks.append([path, name, None])
    return marks


def _scan() -> Installed:
    from importlib import metadata

    try:
        version = metadata.version("hapticfx")
    except metadata.PackageNotFoundError:
        version = "0+unknown"
    found = []
    for ep in metadata.entry_points(group=GROUP):
        dist = ep.dist
        found.append(EntryPoint(ep.name, ep.value, dist.name if dist else "?", dist.version if dist else "?"))
    return Installed(version, tuple(found))


def _kept(path) -> list:
    """The lists kept so far, most recently used first (none when the file is missing or not one this version wrote)."""
    try:
        kept = json.loads(path.read_text())["kept"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    return [entry for entry in kept if isinstance(entry, dict)] if isinstance(kept, list) else []


def _parsed(entry: dict) -> Installed | None:
    try:
        return Installed(str(entry["hapticfx_version"]),
                         tuple(EntryPoint(*(str(e[k]) for k in ("name", "value", "distribution", "version")))
                               for e in entry["entry_points"]))
    except (KeyError, TypeError, ValueError):
        return None


def _write(path, kept: list) -> None:
    try:
        with atomic_path(path, make_parents=True) as tmp:
            tmp.write_text(json.dumps({"kept": kept}, indent=1))
    except (OSError, HapticfxError):  # a read-only home: read the metadata again next time
        pass


def installed() -> Installed:
    """hapticfx's version and the ``hapticfx`` entry points, from the cache when nothing installed has changed."""
    path = cache_root() / CACHE_NAME
    mark = fingerprint()
    kept = _kept(path)
    for i, entry in enumerate(kept):
        if entry.get("fingerprint") == mark and (found := _parsed(entry)) is not None:
            if i:  # most recently used first: the one to make room is the least recently used
                _write(path, [entry, *kept[:i], *kept[i + 1:]])
            return found
    found = _scan()
    entry = {"fingerprint": mark, "hapticfx_version": found.hapticfx_version,
             "entry_points": [vars(e) for e in found.entry_points]}
    _write(path, [entry, *(e for e in kept if e.get("fingerprint") != mark)][:KEPT])
    return found
