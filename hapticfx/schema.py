"""The JSON Schema of effect files, generated from the same declarations that validate them."""

from __future__ import annotations

from .effect import ACTUATOR_CORE_KEYS, LimitParams, ObjectParams
from .params import json_schema, params_of
from .registry import Registry, get_registry

SCHEMA_ID = "https://hapticfx.invalid/schema/effect.schema.json"


def _typed_sections(registry: Registry, kind: str, core: dict) -> dict:
    """A section schema: ``type`` picks the plugin; each plugin's Params add the other keys."""
    names = registry.names(kind)
    branches = []
    for name in names:
        params = json_schema(params_of(registry.get(kind, name).resolve()))
        props = {"type": {"const": name}, **core, **params["properties"]}
        branch = {"if": {"properties": {"type": {"const": name}}},
                  "then": {"properties": props, "additionalProperties": False}}
        if params.get("required"):
            branch["then"]["required"] = params["required"]
        branches.append(branch)
    return {
        "type": "object",
        "required": ["type"],
        "properties": {"type": {"enum": names, "description": f"registered {kind} name"}},
        "allOf": branches,
    }


def _object_schema() -> dict:
    schema = json_schema(ObjectParams)
    schema["properties"]["dimensions_mm"] = {
        "type": "array", "items": {"type": "number", "minimum": 0}, "minItems": 3, "maxItems": 3,
        "description": "width, height, depth (mm)",
    }
    return schema


def effect_schema(registry: Registry | None = None) -> dict:
    """JSON Schema (draft 2020-12) for effect files with the installed plugins."""
    registry = registry or get_registry()
    actuator_core = {
        "device": {"type": ["string", "integer"], "description": "device name or index"},
        "channel": {"type": "integer", "minimum": 0, "description": "output channel"},
        "gain": {"type": "number", "minimum": 0, "maximum": 1, "description": "fraction of full scale"},
        "full_scale_g": {"type": "number", "exclusiveMinimum": 0, "default": 4.0,
                         "description": "acceleration (g) that maps to the actuator's full range"},
        "limits": json_schema(LimitParams),
    }
    assert set(actuator_core) | {"type"} == set(ACTUATOR_CORE_KEYS)
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": SCHEMA_ID,
        "title": "hapticfx effect file",
        "type": "object",
        "additionalProperties": False,
        "required": ["name", "object", "model", "actuator"],
        "properties": {
            "name": {"type": "string", "minLength": 1},
            "description": {"type": "string"},
            "object": {"anyOf": [{"type": "string", "minLength": 1}, _object_schema()],
                       "description": "built-in or dataset object id, or a physical description"},
            "velocity_mps": {"type": "number", "minimum": 0, "maximum": 100, "default": 3.0},
            "model": _typed_sections(registry, "model", {}),
            "actuator": _typed_sections(registry, "actuator", actuator_core),
        },
    }
