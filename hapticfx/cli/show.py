"""Printing a nested description for people (indented ``key: value`` lines) or for programs (JSON)."""

from __future__ import annotations

import json

import typer


def _scalar(value) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    return "-" if value is None else str(value)


def readable(value, indent: int = 0) -> list[str]:
    """``value`` (mappings, lists, scalars) as indented lines; a list of scalars stays on one line."""
    pad = "  " * indent
    lines = []
    for key, item in value.items():
        label = str(key).replace("_", " ")
        if isinstance(item, dict):
            lines.append(f"{pad}{label}:")
            lines += readable(item, indent + 1)
        elif isinstance(item, (list, tuple)) and any(isinstance(x, (dict, list, tuple)) for x in item):
            lines.append(f"{pad}{label}:")
            for x in item:
                lines += readable(x, indent + 1) if isinstance(x, dict) else [f"{pad}  - {_scalar(x)}"]
        elif isinstance(item, (list, tuple)):
            lines.append(f"{pad}{label}: {', '.join(_scalar(x) for x in item) or '-'}")
        else:
            lines.append(f"{pad}{label}: {_scalar(item)}")
    return lines


def show(value: dict, *, as_json: bool) -> None:
    """Echo ``value`` readable, or as indented JSON when ``as_json``."""
    if as_json:
        typer.echo(json.dumps(value, indent=2, default=str))
    else:
        typer.echo("\n".join(readable(value)))


JSON_HELP = "Print JSON (for programs) instead of the readable summary."
