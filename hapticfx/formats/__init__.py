"""Platform haptic files: export an impact to them and play the files others wrote.

Formats are plugins (``register_formats``); the built-ins are ``haptic`` (Meta ``.haptic``
1.0), ``ahap`` (Apple), ``android`` (``VibrationEffect`` arguments), ``android-ogg``
(audio-coupled haptics) and ``hjif`` (MPEG-I Haptics). See docs/formats.md for what each holds, the mappings and the round-trip errors.
"""

from __future__ import annotations

from pathlib import Path

from .base import Decoded, ExportOptions, Format, HapticFileError, suffix_of

__all__ = ["Decoded", "ExportOptions", "Format", "HapticFileError", "all_formats", "format_for", "format_named"]


def all_formats(registry=None) -> list[Format]:
    """One instance of every registered format."""
    from ..registry import get_registry

    registry = registry or get_registry()
    return [registry.create("format", name) for name in registry.names("format")]


def format_named(name: str, registry=None) -> Format:
    """The registered format ``name`` (a :class:`~hapticfx.errors.PluginError` names the installed ones)."""
    from ..registry import get_registry

    return (registry or get_registry()).create("format", name)


def format_for(path: str | Path, registry=None) -> Format | None:
    """The format that reads ``path`` (by its name's ending), or None."""
    return suffix_of(Path(path), all_formats(registry))
