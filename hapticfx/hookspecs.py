"""Hook specifications: what a hapticfx plugin can provide.

Every ``register_*`` hook receives a host-owned ``register(name, factory)``
callback. The host validates each registration and rejects a name that
another plugin already registered, naming both plugins. A factory is a class
or a :func:`hapticfx.registry.lazy` reference (``"package.module:Class"``),
so that discovering a plugin never imports its heavy dependencies.
"""

from __future__ import annotations

from typing import Any, Callable

import pluggy

hookspec = pluggy.HookspecMarker("hapticfx")
hookimpl = pluggy.HookimplMarker("hapticfx")

Register = Callable[[str, Any], None]

# --- components: called once when the registry is first built -----------------


@hookspec
def register_reducers(register: Register) -> None:
    """Register reducers (3-axis to 1-axis), e.g. ``register("max-min", MaxMinReducer)``."""


@hookspec
def register_interpolators(register: Register) -> None:
    """Register interpolators that predict a profile from its two recorded neighbours."""


@hookspec
def register_models(register: Register) -> None:
    """Register impact models that render an :class:`~hapticfx.interfaces.Impact` to a signal."""


@hookspec
def register_actuators(register: Register) -> None:
    """Register actuators (output devices) by the ``type`` name effect files use."""


@hookspec
def register_formats(register: Register) -> None:
    """Register platform haptic file formats (:class:`~hapticfx.formats.Format`) by ``hapticfx export --format`` name."""


# --- command line: called once when the ``hapticfx`` CLI starts ------------------


@hookspec
def register_commands(app: Any, bench: Any, data: Any) -> None:
    """Add Typer commands to the root ``app``, the ``bench`` group or the ``data`` group."""
