"""What the commands' number options need beyond click's types."""

from __future__ import annotations

import math

import typer


def finite(value):
    """Option callback: refuse NaN and infinity, which click's ``min=``/``max=`` range check lets through
    (NaN fails every comparison, so it is never out of range). Works for a single value or a list."""
    for v in value if isinstance(value, (list, tuple)) else (value,):
        if v is not None and not math.isfinite(v):
            raise typer.BadParameter(f"{v} is not a finite number.")
    return value
