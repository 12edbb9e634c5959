"""Scene files: which effect each simulated object triggers, on which actuator, from which events.

A scene (YAML, safe loader, unknown keys are errors naming file and key path)::

    name: earthquake-room
    actuators:                      # shared outputs, by name; same keys as an effect's actuator
      helmet: {type: wav, path: helmet.wav}
    effects:                        # object id (what the simulator sends) -> effect
      concrete-brick: ../effects/falling_brick.yaml          # path, relative to this file
      steel-plate: {effect: ../effects/steel_plate.yaml, actuator: helmet, channel: 0}
      plastic-frame:
        actuator: helmet
        inline: {name: frame, object: plastic-frame, model: {type: kinetic-energy}, actuator: {type: memory}}
    events:
      osc: {host: 127.0.0.1, port: 9000}
    engine: {queue_size: 256}

An entry that names a scene ``actuator`` plays on it instead of its own
effect's actuator section (which is then validated for structure only, so a
scene can reroute an effect written for hardware it lacks); the effect's own
``limits`` still hold there: the scene may lower a limit, never raise it.
Entries that name the same scene actuator, or actuators that resolve to the
same device and channel, share one opened actuator and one limiter. Building a scene builds
only the models, plugins, datasets and weights its effects reference.

An optional ``head`` puts several actuators on the head, each a channel of one
scene actuator (``head: {actuator: helmet, sites: {crown: {position: [0, 0,
0.13], channel: 0}, ...}}``); entries on that actuator are spread over them by
where each impact lands (:mod:`hapticfx.spatial`) and name no channel.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .effect import ActuatorSection, Effect, LimitParams, effect_from_mapping, parse_actuator_section, read_yaml
from .atomic import user_path
from .errors import EffectError, preview
from .params import doc, parse_params
from .spatial import HeadLayout, parse_head

TOP_KEYS = ("name", "description", "actuators", "head", "effects", "events", "engine")
ENTRY_KEYS = ("effect", "inline", "actuator", "channel")


@dataclass(frozen=True)
class OscSettings:
    """``events.osc``: where ``hapticfx serve`` listens and what it tolerates."""

    host: str = field(default="127.0.0.1", metadata=doc(
        "address to bind; 127.0.0.1 keeps it local; any other needs `hapticfx serve --allow-remote`"))
    port: int = field(default=9000, metadata=doc("UDP port; 0 picks a free one", min=0, max=65535))
    max_datagram: int = field(default=1024, metadata=doc("larger datagrams are dropped (bytes)", min=16, max=65507))
    rate_hz: float = field(default=2000.0, metadata=doc("token-bucket rate of datagrams per second; 0: unlimited", min=0.0))
    burst: int = field(default=500, metadata=doc("token-bucket depth (datagrams)", min=1, max=1_000_000))


@dataclass(frozen=True)
class EngineSettings:
    """``engine``: the render queue of :class:`hapticfx.Engine`."""

    queue_size: int = field(default=256, metadata=doc("impacts waiting to render; beyond it they are dropped", min=1, max=1_000_000))
    close_timeout_s: float = field(default=5.0, metadata=doc("how long close() waits for queued impacts (s)", min=0.0, max=3600.0))


@dataclass(frozen=True)
class SceneEntry:
    """One object id of the scene and the effect it triggers; ``output`` names its actuator group."""

    object_id: str
    effect: Effect
    output: str


@dataclass(frozen=True)
class Scene:
    """A validated scene file."""

    name: str
    source: str
    entries: dict[str, SceneEntry]
    osc: OscSettings | None
    engine: EngineSettings
    description: str = ""
    head: HeadLayout | None = None  # several actuators on the head (hapticfx.spatial); None: one, as in the paper

    @property
    def objects(self) -> list[str]:
        return list(self.entries)


def _rekey(exc: EffectError, *, source: str, prefix: str) -> EffectError:
    """The same error, re-homed under ``prefix`` of the scene file."""
    text = str(exc)
    for part in (f"{exc.source}: " if exc.source else "", f"{exc.key}: " if exc.key else ""):
        if part and text.startswith(part):
            text = text[len(part):]
    inner = exc.key if exc.key and exc.key != "(top level)" else ""
    return EffectError(text, source=source, key=f"{prefix}.{inner}" if inner else prefix)


def _channel(value: Any, *, source: str, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise EffectError(f"expected a channel number >= 0, got {preview(value)}", source=source, key=key)
    return value


def _entry(object_id: Any, raw: Any, *, source: str, base_dir: Path, actuators: dict[str, ActuatorSection]) -> SceneEntry:
    key = f"effects.{object_id}"
    if not isinstance(object_id, str) or not object_id.strip() or len(object_id) > 200:
        raise EffectError(f"object ids are non-empty strings, got {preview(object_id)}", source=source, key="effects")
    if isinstance(raw, str):
        raw = {"effect": raw}
    if not isinstance(raw, dict):
        raise EffectError(
            f"expected an effect file path or a mapping with {', '.join(ENTRY_KEYS)}, got {preview(raw)}", source=source, key=key
        )
    unknown = [k for k in raw if k not in ENTRY_KEYS]
    if unknown:
        raise EffectError(f"unknown key {preview(unknown[0])}; allowed: {', '.join(ENTRY_KEYS)}", source=source, key=key)
    if ("effect" in raw) == ("inline" in raw):
        raise EffectError("give exactly one of 'effect' (a file) or 'inline' (an effect mapping)", source=source, key=key)
    if "effect" in raw:
        if not isinstance(raw["effect"], str) or not raw["effect"].strip():
            raise EffectError(f"expected a file path, got {preview(raw['effect'])}", source=source, key=f"{key}.effect")
        path = user_path(raw["effect"])
        path = path if path.is_absolute() else base_dir / path
        effect = effect_from_mapping(read_yaml(path), source=str(path), base_dir=path.resolve().parent)
    else:
        try:
            effect = effect_from_mapping(raw["inline"], source=source, base_dir=base_dir)
        except EffectError as exc:
            raise _rekey(exc, source=source, prefix=f"{key}.inline") from None
        if effect.source == source:
            effect = dataclasses.replace(effect, source=f"{source} ({key}.inline)")
    output = object_id
    if "actuator" in raw:
        name = raw["actuator"]
        if not isinstance(name, str) or name not in actuators:
            raise EffectError(
                f"unknown actuator {preview(name)}; the scene's actuators: {', '.join(actuators) or 'none'}",
                source=source, key=f"{key}.actuator",
            )
        own = effect.own_limits
        if effect.actuator.limits != LimitParams():  # the effect's own limits hold wherever it is routed
            own += ((effect.actuator.limits, effect.source),)
        effect = dataclasses.replace(effect, actuator=actuators[name], own_limits=own,
                                     actuator_at=(source, f"actuators.{name}"))
        output = f"actuators.{name}"
    if "channel" in raw:
        channel = _channel(raw["channel"], source=source, key=f"{key}.channel")
        # the scene actuator's own channel (0 where it names none) is the same output as no channel at all
        same = "actuator" in raw and channel == (actuators[raw["actuator"]].channel or 0)
        effect = dataclasses.replace(effect, actuator=dataclasses.replace(effect.actuator, channel=channel))
        output = output if same else f"{output}#{channel}"
    return SceneEntry(object_id, effect, output)


def scene_from_mapping(data: Any, *, source: str, base_dir: Path) -> Scene:
    """Validate a scene mapping; effect files it names are read and validated too."""
    if data is None:
        raise EffectError("the file is empty; a scene needs name and effects", source=source)
    if not isinstance(data, dict):
        raise EffectError(f"expected a mapping, got {type(data).__name__}", source=source, key="(top level)")
    unknown = [k for k in data if k not in TOP_KEYS]
    if unknown and "model" in data and "effects" not in data:
        raise EffectError("an effect (a model, no effects), not a scene: play it with `hapticfx play FILE`, or list "
                          "it under a scene's effects", source=source, key="(top level)")
    if unknown:
        raise EffectError(f"unknown key {preview(unknown[0])}; allowed: {', '.join(TOP_KEYS)}", source=source, key="(top level)")
    for required in ("name", "effects"):
        if required not in data:
            raise EffectError(f"required key {preview(required)} is missing", source=source, key="(top level)")
    name = data["name"]
    if not isinstance(name, str) or not name.strip():
        raise EffectError(f"expected a non-empty string, got {preview(name)}", source=source, key="name")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise EffectError(f"expected a string, got {preview(description)}", source=source, key="description")

    raw_actuators = data.get("actuators") or {}
    if not isinstance(raw_actuators, dict):
        raise EffectError(f"expected a mapping of name -> actuator, got {preview(raw_actuators)}", source=source, key="actuators")
    actuators = {
        str(n): parse_actuator_section(a, source=source, key=f"actuators.{n}") for n, a in raw_actuators.items()
    }

    raw_effects = data["effects"]
    if not isinstance(raw_effects, dict) or not raw_effects:
        raise EffectError("expected a non-empty mapping of object id -> effect", source=source, key="effects")
    entries = {
        oid: _entry(oid, raw, source=source, base_dir=base_dir, actuators=actuators) for oid, raw in raw_effects.items()
    }
    head = parse_head(data["head"], source=source, actuators=actuators) if data.get("head") is not None else None
    if head is not None:
        if not any(isinstance(raw, dict) and raw.get("actuator") == head.actuator for raw in raw_effects.values()):
            raise EffectError(f"no effect plays on {head.actuator!r}: give the objects that land on the head "
                              f"`actuator: {head.actuator}`", source=source, key="head.actuator")
        for oid, raw in raw_effects.items():
            if isinstance(raw, dict) and raw.get("actuator") == head.actuator and "channel" in raw:
                raise EffectError(f"actuator {head.actuator!r} is the head's: its channels are the sites under "
                                  "head.sites, not chosen per effect", source=source, key=f"effects.{oid}.channel")

    events = data.get("events") or {}
    if not isinstance(events, dict):
        raise EffectError(f"expected a mapping, got {preview(events)}", source=source, key="events")
    unknown = [k for k in events if k != "osc"]
    if unknown:
        raise EffectError(f"unknown event source {preview(unknown[0])}; allowed: osc", source=source, key="events")
    osc = parse_params(OscSettings, events["osc"], source=source, key="events.osc") if "osc" in events else None
    engine = parse_params(EngineSettings, data.get("engine"), source=source, key="engine")
    return Scene(name, source, entries, osc, engine, description, head)


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file (and the effect files it names)."""
    path = Path(path)
    return scene_from_mapping(read_yaml(path), source=str(path), base_dir=path.resolve().parent)


def stand_in_for(device: str | int | None, output: str, n_outputs: int) -> str | int | None:
    """The ``--device`` override for one output group; ``wav:PATH`` or ``csv:PATH`` gets one file per group."""
    kind, _, file = device.partition(":") if isinstance(device, str) else ("", "", "")
    if n_outputs > 1 and kind in ("wav", "csv") and file:
        path = Path(file)
        tag = "".join(c if c.isalnum() or c in "-_" else "_" for c in output)
        return f"{kind}:{path.with_name(f'{path.stem}-{tag}{path.suffix}')}"
    return device


__all__ = ["EngineSettings", "OscSettings", "Scene", "SceneEntry", "load_scene", "scene_from_mapping"]
