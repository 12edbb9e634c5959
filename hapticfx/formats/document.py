"""Reading and writing the JSON documents of haptic files, with errors that name the file and the JSON path.

Strict JSON for ``.haptic``, ``.hjif`` and Android files; JSON5 (the maintained ``json5``
parser) for AHAP and ACF files, which real tools write with trailing commas and
comments. A path in a message is written like ``$.signals.continuous.envelopes.amplitude[3].time``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..atomic import atomic_path
from .base import HapticFileError

MAX_DOCUMENT_BYTES = 32 << 20  # a long clip with dense breakpoints is a few MB


def load_document(path: Path, *, lenient: bool = False) -> Any:
    """Parse ``path`` as JSON (or JSON5 when ``lenient``); every failure is one :class:`HapticFileError`."""
    source = str(path)
    try:
        if not path.is_file():
            raise HapticFileError("file not found" if not path.exists() else "not a file", source=source)
        size = path.stat().st_size
        if size > MAX_DOCUMENT_BYTES:
            raise HapticFileError(f"{size} bytes; a haptic file here holds at most {MAX_DOCUMENT_BYTES}", source=source)
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise HapticFileError(f"cannot read: {exc.strerror if isinstance(exc, OSError) else exc}", source=source) from None
    if lenient:
        try:  # JSON is JSON5: the strict parser first, ~100 times faster than json5 on files that need no leniency
            return json.loads(text, parse_constant=_reject_constant)
        except (ValueError, RecursionError):
            pass
        import json5

        try:
            return json5.loads(text)
        except (ValueError, RecursionError) as exc:
            raise HapticFileError(f"not JSON5: {exc}", source=source, key="$") from None
    try:
        return json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise HapticFileError(f"not JSON: line {exc.lineno}, column {exc.colno}: {exc.msg}", source=source,
                              key="$") from None
    except (ValueError, RecursionError) as exc:
        raise HapticFileError(f"not JSON: {exc}", source=source, key="$") from None


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def write_document(path: Path, doc: Any, *, indent: int | None = 2) -> None:
    """Write ``doc`` as strict JSON (no NaN), atomically."""
    text = json.dumps(doc, indent=indent, allow_nan=False) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


class Reader:
    """Typed access to a parsed document; every error names the file, the JSON path and the rule."""

    def __init__(self, source: str, rules: str):
        self.source = source
        self.rules = rules  # e.g. ".haptic 1.0": said after each rule

    def fail(self, where: str, message: str, rule: str | None = None):
        suffix = f" ({self.rules}: {rule})" if rule else ""
        raise HapticFileError(f"{where}: {message}{suffix}", source=self.source)  # a JSON path may be long: not a key

    def key(self, node: Any, name: str, where: str, *, required: bool = True, default: Any = None) -> Any:
        if not isinstance(node, dict):
            self.fail(where, f"expected an object, got {type(node).__name__}", "structure")
        if name not in node:
            if required:
                self.fail(where, f"required key {name!r} is missing", "required fields")
            return default
        return node[name]

    def array(self, node: Any, where: str) -> list:
        if not isinstance(node, list):
            self.fail(where, f"expected an array, got {type(node).__name__}", "structure")
        return node

    def number(self, node: Any, where: str, *, integer: bool = False) -> float:
        if isinstance(node, bool) or not isinstance(node, (int, float)) or (integer and not isinstance(node, int)):
            self.fail(where, f"expected {'an integer' if integer else 'a number'}, got {node!r}"[:120], "types")
        if isinstance(node, int) and abs(node) > 1e300:
            self.fail(where, f"expected a number of ordinary size, got one of {len(str(node))} digits", "types")
        if not math.isfinite(node):
            self.fail(where, f"expected a finite number, got {node}", "types")
        return node if integer else float(node)

    def ranged(self, node: Any, where: str, lo: float, hi: float, rule: str = "value ranges") -> float:
        value = self.number(node, where)
        if not lo <= value <= hi:
            self.fail(where, f"{value:g} is out of range {lo:g}-{hi:g}", rule)
        return value


def atomic_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
