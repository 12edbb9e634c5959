"""Typed parameters for plugins: parse a YAML mapping into a frozen dataclass.

A model or actuator class declares ``Params`` (a frozen dataclass). Field types
may be ``int``, ``float``, ``str``, ``bool``, ``X | None`` and ``Literal[...]``;
``metadata`` may hold ``min``, ``max`` and ``doc``. The same declaration gives
the error messages (file, key path, what is allowed) and the JSON Schema.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

from .errors import EffectError, preview
from .objects import ObjectInfo

if typing.TYPE_CHECKING:
    from .registry import Registry


@dataclass(frozen=True)
class BuildContext:
    """What a model or actuator may need to know about the effect building it; ``registry``: the one the
    effect is built from (None: the process-wide one), where a model finds its reducers and interpolators."""

    source: str = "<python>"
    base_dir: Path = Path(".")
    object_id: str = ""
    object_info: ObjectInfo | None = None
    device: str | int | None = None
    channel: int | None = None
    registry: Registry | None = None

    def components(self) -> Registry:
        """``registry``, or the process-wide one where none was given."""
        from .registry import get_registry

        return self.registry or get_registry()


@dataclass(frozen=True)
class NoParams:
    """For components that take no parameters."""


def params_of(cls) -> type:
    """The ``Params`` dataclass a component class declares (or :class:`NoParams`)."""
    return getattr(cls, "Params", NoParams)


def _type_name(tp) -> str:
    origin = get_origin(tp)
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(tp))
    if origin in (typing.Union, types.UnionType):
        return " or ".join("null" if a is type(None) else _type_name(a) for a in get_args(tp))
    names = {int: "an integer", float: "a number", str: "a string", bool: "true or false", dict: "a mapping"}
    return names.get(tp, str(tp))


def _coerce(value: Any, tp, where: str, source: str):
    origin = get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = get_args(tp)
        if value is None and type(None) in args:
            return None
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _coerce(value, arg, where, source)
            except EffectError:
                continue
        raise EffectError(f"expected {_type_name(tp)}, got {preview(value)}", source=source, key=where)
    if origin is Literal:
        if value in get_args(tp) and type(value) is type(next(a for a in get_args(tp) if a == value)):
            return value
        raise EffectError(f"expected {_type_name(tp)}, got {preview(value)}", source=source, key=where)
    if tp is dict:
        if isinstance(value, dict) and all(isinstance(k, str) for k in value):
            return dict(value)
    elif tp is bool:
        if isinstance(value, bool):
            return value
    elif tp is int:
        if isinstance(value, int) and not isinstance(value, bool) and abs(value) <= 2**63:
            return value
    elif tp is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if isinstance(value, int) and abs(value) > 1e300:
                raise EffectError(f"expected a number of ordinary size, got {preview(value)}", source=source, key=where)
            if not math.isfinite(value):
                raise EffectError(f"expected a finite number, got {preview(value)}", source=source, key=where)
            return float(value)
    elif tp is str:
        if isinstance(value, str):
            return value
    else:
        raise TypeError(f"unsupported Params field type {preview(tp)} at {where}")
    raise EffectError(f"expected {_type_name(tp)}, got {type(value).__name__} {preview(value)}", source=source, key=where)


def parse_params(cls: type, mapping: Any, *, source: str, key: str, also: tuple[str, ...] = ()):
    """Build ``cls`` (a Params dataclass) from ``mapping``; errors name ``source`` and ``key``. ``also``: keys of
    the same mapping that the caller reads itself (taken out of ``mapping``), listed with the allowed ones."""
    if mapping is None:
        mapping = {}
    if not isinstance(mapping, dict):
        raise EffectError(f"expected a mapping, got {type(mapping).__name__}", source=source, key=key)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    unknown = [k for k in mapping if k not in fields]
    if unknown:
        allowed = ", ".join((*also, *fields)) or "none"
        raise EffectError(f"unknown key {preview(unknown[0])}; allowed: {allowed}", source=source, key=key)
    values = {}
    for name, f in fields.items():
        where = f"{key}.{name}"
        if name not in mapping:
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise EffectError(f"required key {preview(name)} is missing", source=source, key=key)
            continue
        value = _coerce(mapping[name], hints[name], where, source)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            lo, hi = f.metadata.get("min"), f.metadata.get("max")
            if lo is not None and value < lo:
                raise EffectError(f"must be >= {lo}, got {value}", source=source, key=where)
            if hi is not None and value > hi:
                raise EffectError(f"must be <= {hi}, got {value}", source=source, key=where)
        values[name] = value
    return cls(**values)


def _schema_of_type(tp) -> dict:
    origin = get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return {"anyOf": [_schema_of_type(a) for a in get_args(tp)]}
    if origin is Literal:
        return {"enum": list(get_args(tp))}
    return {
        bool: {"type": "boolean"}, int: {"type": "integer"}, float: {"type": "number"},
        str: {"type": "string"}, type(None): {"type": "null"}, dict: {"type": "object"},
    }[tp]


def json_schema(cls: type) -> dict:
    """JSON Schema (draft 2020-12 fragment) of a Params dataclass."""
    hints = typing.get_type_hints(cls)
    props, required = {}, []
    for f in dataclasses.fields(cls):
        s = _schema_of_type(hints[f.name])
        if "min" in f.metadata:
            s["minimum"] = f.metadata["min"]
        if "max" in f.metadata:
            s["maximum"] = f.metadata["max"]
        if "doc" in f.metadata:
            s["description"] = f.metadata["doc"]
        if f.default is not dataclasses.MISSING:
            s["default"] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            s["default"] = f.default_factory()
        else:
            required.append(f.name)
        props[f.name] = s
    out = {"type": "object", "properties": props, "additionalProperties": False}
    if required:
        out["required"] = required
    return out


def doc(text: str, **bounds) -> dict:
    """Field metadata: ``field(default=..., metadata=doc("what it is", min=0))``."""
    return {"doc": text, **bounds}
