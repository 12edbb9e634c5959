"""Effect files: YAML read with a safe loader and validated into typed objects.

Structure checks happen here (keys, types, ranges, the object). What a model
or actuator accepts is declared by its class's ``Params``; :func:`check_effect`
resolves the plugins and validates those too, without opening any device.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .errors import EffectError, HapticfxError, one_line, preview
from .interfaces import SafetyLimits
from .objects import ObjectInfo, builtin_object
from .params import BuildContext, params_of, parse_params
from .registry import Registry, get_registry


MAX_YAML_BYTES = 1 << 20  # an effect, scene or spec is a few kB; a larger file is not one
MAX_YAML_ALIASES = 64
MAX_YAML_DEPTH = 32


class _StrictLoader(yaml.SafeLoader):
    """The safe loader with bounded cost: no repeated mapping keys, few aliases, shallow nesting."""

    def __init__(self, stream):
        super().__init__(stream)
        self._aliases = 0
        self._depth = 0

    def compose_node(self, parent, index):
        event = self.peek_event()
        if getattr(event, "tag", None) not in (None, "!"):
            raise yaml.composer.ComposerError(None, None, f"tag {one_line(event.tag, 80)!r} is not allowed (these files hold "
                                              "plain mappings, lists, strings and numbers)", event.start_mark)
        if self.check_event(yaml.events.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_YAML_ALIASES:
                raise yaml.composer.ComposerError(None, None, f"more than {MAX_YAML_ALIASES} aliases",
                                                  self.peek_event().start_mark)
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise yaml.composer.ComposerError(None, None, f"nested deeper than {MAX_YAML_DEPTH} levels",
                                                  self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _mapping_without_duplicates(loader: _StrictLoader, node: yaml.MappingNode, deep: bool = False):
    seen = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if not isinstance(key, (str, int, float, bool)) and key is not None:
            raise yaml.constructor.ConstructorError(
                None, None, f"a mapping key must be a string or a number, got {type(key).__name__}", key_node.start_mark)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {preview(key)} (first at line {seen[key] + 1})", key_node.start_mark
            )
        seen[key] = key_node.start_mark.line
    return loader.construct_mapping(node, deep=deep)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping_without_duplicates)
# YAML 1.1 wants a dot and a signed exponent in a float: 1e12 and 1.5e3 would be text; read them as numbers,
# as YAML 1.2 and JSON do
_StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."))


def read_yaml(path: Path) -> Any:
    """Parse a YAML file safely, at a bounded cost; every failure is an :class:`EffectError` naming the file."""
    path = Path(path)
    try:
        if not path.is_file():
            raise EffectError("file not found" if not path.exists() else "not a file", source=str(path))
        if path.stat().st_size > MAX_YAML_BYTES:
            raise EffectError(f"{path.stat().st_size} bytes; a YAML file here holds at most {MAX_YAML_BYTES}",
                              source=str(path))
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise EffectError(f"cannot read: {exc.strerror}", source=str(path)) from None
    except UnicodeDecodeError as exc:
        raise EffectError(f"not a YAML text file (byte {exc.start} is not UTF-8 text); expected an effect, scene or "
                          "study file" + ("; a WAV file goes to `hapticfx export`" if path.suffix.lower() == ".wav"
                                          else ""), source=str(path)) from None
    loader = None
    try:
        loader = _StrictLoader(text)
        return loader.get_single_data()
    except yaml.constructor.ConstructorError as exc:
        mark = exc.problem_mark
        where = f"line {mark.line + 1}: " if mark else ""
        if exc.problem and "constructor for the tag" in exc.problem:
            tag = exc.problem.split("tag ", 1)[-1]
            raise EffectError(
                f"{where}tag {tag} is not allowed (effect files hold plain mappings, lists, strings and numbers)",
                source=str(path),
            ) from None
        raise EffectError(f"{where}{exc.problem}", source=str(path)) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise EffectError(f"invalid YAML: {where}{problem}", source=str(path)) from None
    except (ValueError, TypeError, OverflowError, RecursionError) as exc:
        raise EffectError(f"invalid YAML value: {exc}", source=str(path)) from None
    finally:
        if loader is not None:
            loader.dispose()


@dataclass(frozen=True)
class ObjectParams:
    """A physical description of an object, for objects that are not built in."""

    id: str
    mass_kg: float = field(metadata={"min": 1e-6, "max": 1e4, "doc": "mass (kg)"})
    name: str | None = None
    material: str = "unknown"


@dataclass(frozen=True)
class LimitParams:
    """Limits an effect may lower (never raise) below the actuator's hard limits."""

    peak: float | None = field(default=None, metadata={"min": 0.0, "max": 1.0, "doc": "peak, fraction of full scale"})
    rms: float | None = field(default=None, metadata={"min": 0.0, "max": 1.0, "doc": "RMS ceiling, fraction of full scale"})
    rms_window_s: float | None = field(default=None, metadata={"min": 1e-4, "max": 60.0, "doc": "RMS window (s); may only shrink"})
    max_on_s: float | None = field(default=None, metadata={"min": 0.0, "max": 60.0, "doc": "longest pulse (s)"})
    max_duty: float | None = field(default=None, metadata={"min": 0.0, "max": 1.0, "doc": "duty cycle ceiling"})


@dataclass(frozen=True)
class Section:
    """A model or actuator section: the plugin type and its remaining keys."""

    type: str
    options: dict


@dataclass(frozen=True)
class ActuatorSection(Section):
    """The actuator section: type, core routing and gain, limits, plugin options."""

    device: str | int | None = None
    channel: int | None = None
    gain: float | None = None
    full_scale_g: float = 4.0
    limits: LimitParams = LimitParams()


@dataclass(frozen=True)
class Effect:
    """A validated effect file."""

    name: str
    object_id: str
    object_info: ObjectInfo | None
    velocity_mps: float
    model: Section
    actuator: ActuatorSection
    source: str
    base_dir: Path
    description: str = ""
    # the limits of the effect's own actuator section, with the file that set them, kept where a scene
    # routes the effect to another actuator: they still hold there (the strictest wins)
    own_limits: tuple[tuple[LimitParams, str], ...] = ()
    actuator_at: tuple[str, str] = ()  # (file, key) of the actuator section, where not the effect file's (a scene's)

    def context(self, *, device=None, registry: Registry | None = None) -> BuildContext:
        return BuildContext(
            source=self.source, base_dir=self.base_dir, object_id=self.object_id, object_info=self.object_info,
            device=self.actuator.device if device is None else device, channel=self.actuator.channel,
            registry=registry,
        )


TOP_KEYS = ("name", "description", "object", "velocity_mps", "model", "actuator")
ACTUATOR_CORE_KEYS = ("type", "device", "channel", "gain", "full_scale_g", "limits")


def _require_mapping(value, *, source: str, key: str) -> dict:
    if not isinstance(value, dict):
        raise EffectError(f"expected a mapping, got {type(value).__name__} {preview(value)}", source=source, key=key)
    return value


def _str(value, *, source, key) -> str:
    if not isinstance(value, str) or not value.strip():
        raise EffectError(f"expected a non-empty string, got {preview(value)}", source=source, key=key)
    return value


def _number(value, *, source, key, minimum=None, maximum=None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise EffectError(f"expected a number, got {type(value).__name__} {preview(value)}", source=source, key=key)
    if isinstance(value, int) and abs(value) > 1e300:
        raise EffectError(f"expected a number of ordinary size, got {preview(value)}", source=source, key=key)
    if not math.isfinite(value):
        raise EffectError(f"expected a finite number, got {preview(value)}", source=source, key=key)
    if minimum is not None and value < minimum:
        raise EffectError(f"must be >= {minimum}, got {value}", source=source, key=key)
    if maximum is not None and value > maximum:
        raise EffectError(f"must be <= {maximum}, got {value}", source=source, key=key)
    return float(value)


def _object(value, *, source) -> tuple[str, ObjectInfo | None]:
    if isinstance(value, str):
        try:
            return value, builtin_object(value, source=source)
        except EffectError:
            return value, None  # a dataset object id; the model checks it exists
    raw = dict(_require_mapping(value, source=source, key="object"))
    dims = raw.pop("dimensions_mm", (0.0, 0.0, 0.0))
    if not isinstance(dims, (list, tuple)) or len(dims) != 3:
        raise EffectError(f"expected [width, height, depth] in mm, got {preview(dims)}", source=source, key="object.dimensions_mm")
    dims = tuple(_number(d, source=source, key="object.dimensions_mm", minimum=0.0, maximum=1e5) for d in dims)
    p = parse_params(ObjectParams, raw, source=source, key="object", also=("dimensions_mm",))
    return p.id, ObjectInfo(p.id, p.name or p.id, p.mass_kg, dims, p.material)


def parse_actuator_section(raw: Any, *, source: str, key: str = "actuator") -> ActuatorSection:
    """Validate an actuator section (core keys here; the plugin's own keys at build time)."""
    act_raw = dict(_require_mapping(raw, source=source, key=key))
    if "type" not in act_raw:
        raise EffectError("required key 'type' is missing", source=source, key=key)
    core = {k: act_raw.pop(k) for k in ACTUATOR_CORE_KEYS if k in act_raw}
    device = core.get("device")
    if device is not None and (isinstance(device, bool) or not isinstance(device, (str, int))):
        raise EffectError(f"expected a device name or index, got {preview(device)}", source=source, key=f"{key}.device")
    channel = core.get("channel")
    if channel is not None and (isinstance(channel, bool) or not isinstance(channel, int) or channel < 0):
        raise EffectError(f"expected a channel number >= 0, got {preview(channel)}", source=source, key=f"{key}.channel")
    gain = core.get("gain")
    if gain is not None:
        gain = _number(gain, source=source, key=f"{key}.gain", minimum=0.0, maximum=1.0)
    full_scale = _number(core.get("full_scale_g", 4.0), source=source, key=f"{key}.full_scale_g",
                         minimum=1e-6, maximum=1e6)
    limits = parse_params(LimitParams, core.get("limits"), source=source, key=f"{key}.limits")
    return ActuatorSection(
        _str(core["type"], source=source, key=f"{key}.type"), act_raw,
        device=device, channel=channel, gain=gain, full_scale_g=full_scale, limits=limits,
    )


def effect_from_mapping(data: Any, *, source: str, base_dir: Path) -> Effect:
    """Validate the structure of an effect mapping (plugins are checked by :func:`check_effect`)."""
    data = _require_mapping(data, source=source, key="(top level)") if data is not None else None
    if data is None:
        raise EffectError("the file is empty; an effect needs name, object, model and actuator", source=source)
    unknown = [k for k in data if k not in TOP_KEYS]
    if unknown and "model" not in data and ("effects" in data or "actuators" in data):
        raise EffectError("a scene (effects and actuators, no model), not an effect: run it with `hapticfx serve "
                          "FILE` or hapticfx.Engine", source=source, key="(top level)")
    if unknown:
        raise EffectError(f"unknown key {preview(unknown[0])}; allowed: {', '.join(TOP_KEYS)}", source=source, key="(top level)")
    for required in ("name", "object", "model", "actuator"):
        if required not in data:
            raise EffectError(f"required key {preview(required)} is missing", source=source, key="(top level)")
    name = _str(data["name"], source=source, key="name")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise EffectError(f"expected a string, got {preview(description)}", source=source, key="description")
    object_id, info = _object(data["object"], source=source)
    velocity = _number(data.get("velocity_mps", 3.0), source=source, key="velocity_mps", minimum=0.0, maximum=100.0)

    model_raw = dict(_require_mapping(data["model"], source=source, key="model"))
    if "type" not in model_raw:
        raise EffectError("required key 'type' is missing", source=source, key="model")
    model = Section(_str(model_raw.pop("type"), source=source, key="model.type"), model_raw)

    actuator = parse_actuator_section(data["actuator"], source=source)
    return Effect(name, object_id, info, velocity, model, actuator, source, base_dir, description)


def haptic_file_effect(path: Path, description: str = "") -> Effect:
    """The effect a haptic file stands for: its ``haptic-file`` model on the default actuator (a vibro-transducer)."""
    path = Path(path)
    return Effect(name=path.name, object_id="haptic-file", object_info=None, velocity_mps=0.0,
                  model=Section("haptic-file", {"file": str(path.resolve())}), actuator=ActuatorSection("vibro-transducer", {}),
                  source=str(path), base_dir=path.resolve().parent, description=description)


def load_effect(path: str | Path) -> Effect:
    """Read and validate the structure of an effect file; a haptic file (``.haptic``, ``.ahap``, ...) stands for
    an effect that plays it (:mod:`hapticfx.formats.effect`)."""
    path = Path(path)
    if path.suffix.lower() not in (".yaml", ".yml"):
        from .formats import format_for

        fmt = format_for(path)
        if fmt is not None:
            return haptic_file_effect(path, fmt.description)
    return effect_from_mapping(read_yaml(path), source=str(path), base_dir=path.resolve().parent)


@dataclass(frozen=True)
class Plan:
    """What building an effect will load: plugin classes and their parsed parameters, from ``registry``."""

    effect: Effect
    model_cls: type
    model_params: Any
    actuator_cls: type
    actuator_params: Any
    registry: Registry

    def model_registration(self):
        return self.registry.get("model", self.effect.model.type)

    def actuator_registration(self):
        return self.registry.get("actuator", self.effect.actuator.type)


def _resolve(registry: Registry, kind: str, name: str, *, source: str, key: str) -> type:
    try:
        return registry.get(kind, name).resolve()
    except HapticfxError as exc:
        raise EffectError(str(exc), source=source, key=key) from None


def _actuator_cls(registry: Registry, name: str, *, source: str, key: str) -> type:
    """The registered actuator ``name``; a first-party sound-card actuator whose plugin is not installed is
    known by its spec (hapticfx.actuators.known): it renders to files, and says what to install to play."""
    from .actuators.known import KNOWN, spec_only

    if name in KNOWN and name not in registry.names("actuator"):
        return spec_only(name)
    return _resolve(registry, "actuator", name, source=source, key=f"{key}.type")


def check_effect(effect: Effect, *, registry: Registry | None = None) -> Plan:
    """Resolve the effect's plugins and validate their parameters; opens nothing."""
    registry = registry or get_registry()
    src, (act_src, act_key) = effect.source, effect.actuator_at or (effect.source, "actuator")
    model_cls = _resolve(registry, "model", effect.model.type, source=src, key="model.type")
    actuator_cls = _actuator_cls(registry, effect.actuator.type, source=act_src, key=act_key)
    model_params = parse_params(params_of(model_cls), effect.model.options, source=src, key="model")
    actuator_params = parse_params(params_of(actuator_cls), effect.actuator.options, source=act_src, key=act_key,
                                   also=ACTUATOR_CORE_KEYS)
    return Plan(effect, model_cls, model_params, actuator_cls, actuator_params, registry)


def effective_limits(hard: SafetyLimits, effect: Effect) -> SafetyLimits:
    """The actuator's hard limits, lowered by the effect's actuator section where it asks, and by the limits
    of the effect's own actuator section where a scene routed it elsewhere: the strictest of them all holds."""
    src, key = effect.actuator_at or (effect.source, "actuator")
    try:
        limits = hard.lowered(**dataclasses.asdict(effect.actuator.limits),
                              source=f"scene {src} {key}" if effect.actuator_at else f"effect {src}")
    except EffectError as exc:
        raise EffectError(str(exc), source=src, key=f"{key}.limits") from None
    for own, source in effect.own_limits:
        try:
            limits = limits.strictest(hard.lowered(**dataclasses.asdict(own), source=f"effect {source}"))
        except EffectError as exc:
            raise EffectError(str(exc), source=source, key="actuator.limits") from None
    return limits
