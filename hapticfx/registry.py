"""The plugin manager and the component registry built from it.

Built-in components are registered through the same hooks as third-party
plugins. Third-party plugins come from the ``hapticfx`` entry-point group (found once and
kept until what is installed changes: :mod:`hapticfx.entrypoints`);
the ``HAPTICFX_PLUGINS`` environment variable, when set, is a comma-separated
allow-list of entry-point names to load (empty: load none).
"""

from __future__ import annotations

import importlib
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pluggy

from . import entrypoints, hookspecs
from .errors import PluginError

KINDS = ("reducer", "interpolator", "model", "actuator", "format")
ALLOW_ENV = "HAPTICFX_PLUGINS"

# What the project's own plugin distributions register, to name the one to install when a name is
# missing (tests/test_hooks.py checks this against what the installed plugins really register).
FIRST_PARTY = {
    ("actuator", "vibro-transducer"): "hapticfx-soundcard",
    ("actuator", "haptuator"): "hapticfx-soundcard",
    ("actuator", "solenoid"): "hapticfx-solenoid",
    **{("interpolator", n): "hapticfx-neural"
       for n in ("convbilstm", "lstm", "bilstm", "lstm-sae", "bilstm-ed", "convlstm-ed")},
}
def install_hint(dist: str) -> str:
    """The command that installs first-party distribution ``dist``: from the source tree hapticfx runs from
    when there is one (the plugins are not on PyPI)."""
    tree = Path(__file__).resolve().parents[1] / "plugins" / dist
    if (tree / "pyproject.toml").is_file():
        return f"pip install {tree}"
    return f"pip install ./plugins/{dist} in hapticfx's source tree (it is not on PyPI)"


BUILTIN_MODULES = ("hapticfx.builtins.core", "hapticfx.builtins.data", "hapticfx.builtins.physics", "hapticfx.builtins.scene",
                   "hapticfx.builtins.study", "hapticfx.builtins.formats")


class lazy:
    """A factory named by ``"package.module:Attribute"``, imported on first use."""

    def __init__(self, target: str):
        if ":" not in target:
            raise ValueError(f"lazy factory must look like 'package.module:Attribute', got {target!r}")
        self.target = target
        self._resolved = None

    def resolve(self):
        if self._resolved is None:
            module_name, attr = self.target.split(":", 1)
            try:
                module = importlib.import_module(module_name)
            except ImportError as exc:
                raise PluginError(f"cannot import {module_name!r} for {self.target!r}: {exc}") from exc
            try:
                self._resolved = getattr(module, attr)
            except AttributeError as exc:
                raise PluginError(f"{module_name!r} has no attribute {attr!r}") from exc
        return self._resolved

    def __call__(self, *args, **kwargs):
        return self.resolve()(*args, **kwargs)

    def __repr__(self):
        return f"lazy({self.target!r})"


@dataclass(frozen=True)
class Registration:
    """One registered component: its kind and name, factory, and where it came from."""

    kind: str
    name: str
    factory: Any
    plugin: str
    distribution: str
    version: str

    def resolve(self):
        """The factory itself (imports a lazy one)."""
        return self.factory.resolve() if isinstance(self.factory, lazy) else self.factory


@dataclass(frozen=True)
class PluginInfo:
    """A loaded plugin and the distribution that provides it."""

    name: str
    distribution: str
    version: str


def create_plugin_manager(*, entry_points: bool = True) -> tuple[pluggy.PluginManager, dict[str, PluginInfo]]:
    """A plugin manager with the built-ins and the allowed entry-point plugins loaded."""
    pm = pluggy.PluginManager("hapticfx")
    pm.add_hookspecs(hookspecs)
    infos: dict[str, PluginInfo] = {}
    installed = entrypoints.installed()
    for module_name in BUILTIN_MODULES:
        pm.register(importlib.import_module(module_name), name=module_name)
        infos[module_name] = PluginInfo(module_name, "hapticfx", installed.hapticfx_version)
    if entry_points:
        allowed = os.environ.get(ALLOW_ENV)
        allow = None if allowed is None else {n.strip() for n in allowed.split(",") if n.strip()}
        for ep in installed.entry_points:
            if allow is not None and ep.name not in allow:
                continue
            if ep.name in infos:
                raise PluginError(f"two plugins are named {ep.name!r}; uninstall one of them")
            try:
                plugin = ep.load()
            except Exception as exc:  # a broken third-party plugin must name itself
                raise PluginError(f"plugin {ep.name!r} ({ep.value}) failed to load: {exc}") from exc
            pm.register(plugin, name=ep.name)
            infos[ep.name] = PluginInfo(ep.name, ep.distribution, ep.version)
    return pm, infos


class Registry:
    """Components of every kind, by name, collected from a plugin manager's hooks."""

    def __init__(self, pm: pluggy.PluginManager, infos: dict[str, PluginInfo]):
        self.pm = pm
        self.plugins = infos
        self._items: dict[tuple[str, str], Registration] = {}
        for kind in KINDS:
            self._collect(kind)

    def _collect(self, kind: str) -> None:
        caller = getattr(self.pm.hook, f"register_{kind}s")
        for impl in caller.get_hookimpls():
            info = self.plugins.get(impl.plugin_name, PluginInfo(impl.plugin_name, "registered at run time", "-"))

            def register(name: str, factory: Any, _info=info, _kind=kind) -> None:
                self._add(_kind, name, factory, _info)

            impl.function(register=register)

    def _add(self, kind: str, name: str, factory: Any, info: PluginInfo) -> None:
        if not isinstance(name, str) or not name or name != name.strip():
            raise PluginError(f"plugin {info.name!r} registered a {kind} with an invalid name {name!r}")
        if not (callable(factory) or isinstance(factory, lazy)):
            raise PluginError(f"plugin {info.name!r} registered {kind} {name!r} with a factory that is not callable")
        key = (kind, name)
        if key in self._items:
            first = self._items[key]
            raise PluginError(
                f"{kind} {name!r} is registered twice: by plugin {first.plugin!r} ({first.distribution}) "
                f"and by plugin {info.name!r} ({info.distribution})"
            )
        self._items[key] = Registration(kind, name, factory, info.name, info.distribution, info.version)

    def names(self, kind: str) -> list[str]:
        return sorted(name for (k, name) in self._items if k == kind)

    def get(self, kind: str, name: str) -> Registration:
        try:
            return self._items[(kind, name)]
        except KeyError:
            where = ""
            dist = FIRST_PARTY.get((kind, name))
            if dist:
                where = f"; it comes with {dist}: {install_hint(dist)}"
            raise PluginError(
                f"unknown {kind} {name!r}{where}; installed: {', '.join(self.names(kind)) or 'none'}"
            ) from None

    def create(self, kind: str, name: str, /, **kwargs) -> Any:
        """Build the component ``name`` of ``kind`` with keyword options."""
        return self.get(kind, name).resolve()(**kwargs)

    def __iter__(self):
        return iter(sorted(self._items.values(), key=lambda r: (KINDS.index(r.kind), r.name)))


_lock = threading.Lock()
_registry: Registry | None = None


def get_registry() -> Registry:
    """The process-wide registry (built on first use)."""
    global _registry
    with _lock:
        if _registry is None:
            _registry = Registry(*create_plugin_manager())
        return _registry


def reset_registry() -> None:
    """Forget the process-wide registry (tests, or after changing ``HAPTICFX_PLUGINS``)."""
    global _registry
    with _lock:
        _registry = None
