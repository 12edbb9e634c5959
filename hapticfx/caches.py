"""The one user cache folder: what hapticfx computes once from installed or shipped files and reuses.

Held-out drop sets (``datasets/``), physics tables (``physics/``), conformance verdicts
(``conformance.json``) and the plugins' entry points (``entry-points.json``) all live here. Deleting the
folder is always safe: each is rebuilt on next use.
"""

from __future__ import annotations

import os
from pathlib import Path

CACHE_ENV = "HAPTICFX_CACHE"


def cache_root() -> Path:
    """``$HAPTICFX_CACHE``, else ``$XDG_CACHE_HOME/hapticfx``, else ``~/.cache/hapticfx``."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "hapticfx"
