"""Simulation spec files: other objects, other velocities per object, another helmet and sensor.

``hapticfx data synth OUT --spec SPEC.yaml`` simulates what a spec describes::

    name: second-rig                  # dataset name (default: OUT's folder name)
    seed: 99                          # default 20230417
    drops: 10                         # per velocity, default 10
    rig:                              # every key optional; defaults: the built-in rig
      receiver: helmet                # a shipped receiver (tabletop, bat-handle, car-seat, boot): the struck body
      helmet: {mass: 2.8, support_hz: 30, modes: [{hz: 152, zeta: 0.04, mass: 1.3,
               order: 1, lateral: 0.04, vertical: 0.06}]}
      sensor: {range_g: 6.0, sensitivity_v_per_g: 0.174}
    objects:
      - {id: ceramic-tile, name: Ceramic tile, mass_kg: 0.12, dimensions_mm: [100, 100, 8],
         material: ceramic, velocities_mps: [1.82, 2.66, 2.94]}

Materials come from the simulator's table (:data:`hapticfx.droprig.contact.MATERIALS`).

An impact family instead (docs/families.md): its effect file gives the striker,
the receiver, the contact law and the side that is felt; the spec gives the
velocities, the drops, the spread and the sensor (on the felt side)::

    family: ../../effects/families/football_kick.yaml   # relative to the spec
    velocities_mps: [5, 10, 20, 40]                      # within the effect's max_velocity_mps
    drops: 5
    variation: {tilt_deg: 1.0, offset_mm: 2.0, stiffness_frac: 0.05}   # any spec: the drop-to-drop spread
    rig:
      sensor: {range_g: 500, sensitivity_v_per_g: 0.01}

Unknown keys, wrong types and out-of-range numbers are errors naming the file and key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from ..effect import read_yaml
from ..errors import EffectError
from ..objects import ObjectInfo
from . import MAX_SEED
from .contact import MATERIALS
from .receiver import RECEIVERS, Receiver, ShellMode
from .sensor import Accelerometer
from .synth import BUILTIN_DROPS, BUILTIN_SEED, Rig, Variation

SPEC_VELOCITIES = (0.05, 50.0)  # m/s: the impact velocities a drop-rig spec (and `data synth --velocities`) takes


@dataclass(frozen=True)
class SynthSpec:
    """A parsed spec: the objects with their own velocities, the rig, drops, seed, name and drop-to-drop spread."""

    objects: list[ObjectInfo]
    velocities: dict[str, list[float]]
    rig: Rig
    drops: int
    seed: int
    name: str | None
    variation: Variation | None = None


def _check_keys(value, allowed, source: str, key: str) -> dict:
    if not isinstance(value, dict):
        raise EffectError("expected a mapping", source=source, key=key)
    unknown = sorted(set(value) - set(allowed))
    if unknown:
        raise EffectError(f"unknown key(s) {', '.join(map(str, unknown))}; allowed: {', '.join(allowed)}",
                          source=source, key=key)
    return value


def _number(value, source: str, key: str, *, minimum: float, maximum: float, integer: bool = False) -> float:
    ok = isinstance(value, int) if integer else isinstance(value, (int, float))
    if isinstance(value, bool) or not ok or not minimum <= value <= maximum:
        kind = "an integer" if integer else "a number"
        raise EffectError(f"expected {kind} in [{minimum:g}, {maximum:g}], got {value!r}", source=source, key=key)
    return value


def _fields(cls, given: dict, source: str, key: str, nested: dict | None = None) -> dict:
    """Keyword arguments for dataclass ``cls`` from ``given``: numbers (or number lists for tuple fields)."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    _check_keys(given, list(fields), source, key)
    out = {}
    for name, value in given.items():
        where = f"{key}.{name}"
        if nested and name in nested:
            out[name] = nested[name](value, where)
        elif isinstance(getattr(cls(), name), tuple):
            default = getattr(cls(), name)
            if not isinstance(value, list) or len(value) != len(default):
                raise EffectError(f"expected a list of {len(default)} numbers", source=source, key=where)
            out[name] = tuple(_number(v, source, where, minimum=-1e9, maximum=1e9) for v in value)
        else:
            integer = isinstance(getattr(cls(), name), int)
            out[name] = _number(value, source, where, minimum=-1e9 if name.startswith("bias") else 1e-9,
                                maximum=1e9, integer=integer)
    return out


def _modes(value, source: str, key: str) -> tuple[ShellMode, ...]:
    if not isinstance(value, list) or not value:
        raise EffectError("expected a non-empty list of modes", source=source, key=key)
    modes = []
    for i, m in enumerate(value):
        where = f"{key}[{i}]"
        m = _check_keys(m, [f.name for f in dataclasses.fields(ShellMode)], source, where)
        missing = [f.name for f in dataclasses.fields(ShellMode) if f.name not in m]
        if missing:
            raise EffectError(f"missing key(s) {', '.join(missing)}", source=source, key=where)
        modes.append(ShellMode(**{k: _number(v, source, f"{where}.{k}", minimum=0.0, maximum=1e6,
                                             integer=k == "order") for k, v in m.items()}))
    return tuple(modes)


def _variation(value, source: str) -> Variation | None:
    if value is None:
        return None
    given = _check_keys(value, [f.name for f in dataclasses.fields(Variation)], source, "variation")
    return Variation(**{k: float(_number(v, source, f"variation.{k}", minimum=0.0, maximum=1e3))
                        for k, v in given.items()})


def _family(data: dict, rig_cfg: dict, path: Path) -> tuple[list[ObjectInfo], dict[str, list[float]], Rig]:
    """The striker, its velocities and the rig of a ``family:`` spec (the effect's contact model)."""
    from ..effect import check_effect, load_effect

    source = str(path)
    if "objects" in data:
        raise EffectError("a family's effect gives the striker; drop 'objects'", source=source, key="objects")
    for key in ("receiver", "helmet"):
        if key in rig_cfg:
            raise EffectError("a family's effect names its receiver; drop it here", source=source, key=f"rig.{key}")
    value = data["family"]
    if not isinstance(value, str) or not value:
        raise EffectError("expected the path of an effect file on the contact model", source=source, key="family")
    effect_path = Path(path).parent / value
    if not effect_path.is_file():
        raise EffectError(f"no effect file {effect_path}", source=source, key="family")
    effect = load_effect(effect_path)
    if effect.model.type != "contact":
        raise EffectError(f"{effect_path}: model.type is {effect.model.type!r}; a family simulates an effect on the "
                          "contact model", source=source, key="family")
    plan = check_effect(effect)
    model = plan.model_cls(plan.model_params, effect.context(device=None))
    info = model.object_for(effect.object_id)
    vmax = model.params.max_velocity_mps
    vs = data.get("velocities_mps")
    if not isinstance(vs, list) or len(vs) < 2:
        raise EffectError("expected a list of at least 2 velocities", source=source, key="velocities_mps")
    velocities = [_number(v, source, "velocities_mps", minimum=1e-3, maximum=vmax) for v in vs]
    sensor = Accelerometer(**_fields(Accelerometer, rig_cfg.get("sensor") or {}, source, "rig.sensor"))
    return [info], {info.id: velocities}, Rig(helmet=model.receiver_model(), sensor=sensor, strike=model.strike)


def load_spec(path: Path) -> SynthSpec:
    """Read and validate a simulation spec (safe YAML loader, strict keys)."""
    source = str(path)
    data = _check_keys(read_yaml(Path(path)),
                       ["name", "seed", "drops", "rig", "objects", "family", "velocities_mps", "variation"],
                       source, "spec")
    rig_cfg = _check_keys(data.get("rig") or {}, ["receiver", "helmet", "sensor"], source, "rig")
    if "family" in data:
        objects, velocities, rig = _family(data, rig_cfg, Path(path))
    else:
        if "velocities_mps" in data:
            raise EffectError("velocities go with each object (objects[i].velocities_mps), or with a family",
                              source=source, key="velocities_mps")
        objects, velocities, rig = _objects(data, rig_cfg, source)
    return SynthSpec(objects, velocities, rig,
                     int(_number(data.get("drops", BUILTIN_DROPS), source, "drops", minimum=1, maximum=1000,
                                 integer=True)),
                     int(_number(data.get("seed", BUILTIN_SEED), source, "seed", minimum=0, maximum=MAX_SEED,
                                 integer=True)),
                     data.get("name"), _variation(data.get("variation"), source))


def _objects(data: dict, rig_cfg: dict, source: str) -> tuple[list[ObjectInfo], dict[str, list[float]], Rig]:
    """The objects, their velocities and the rig of a drop-rig spec."""
    base = rig_cfg.get("receiver", "helmet")
    if base not in RECEIVERS:
        raise EffectError(f"unknown receiver {base!r}; shipped: {', '.join(RECEIVERS)}", source=source,
                          key="rig.receiver")
    changes = _fields(Receiver, rig_cfg.get("helmet") or {}, source, "rig.helmet",
                      nested={"modes": lambda v, k: _modes(v, source, k)})
    helmet = dataclasses.replace(RECEIVERS[base], **changes)  # the named receiver, with the spec's changes
    sensor = Accelerometer(**_fields(Accelerometer, rig_cfg.get("sensor") or {}, source, "rig.sensor"))
    objects, velocities = [], {}
    if not isinstance(data.get("objects"), list) or not data["objects"]:
        raise EffectError("expected a non-empty list of objects", source=source, key="objects")
    for i, o in enumerate(data["objects"]):
        where = f"objects[{i}]"
        o = _check_keys(o, ["id", "name", "mass_kg", "dimensions_mm", "material", "velocities_mps"], source, where)
        if not isinstance(o.get("id"), str) or not o["id"]:
            raise EffectError("expected a non-empty string", source=source, key=f"{where}.id")
        if o["id"] in velocities:
            raise EffectError(f"object {o['id']!r} is listed twice", source=source, key=f"{where}.id")
        material = o.get("material", "unknown")
        if material not in MATERIALS:
            raise EffectError(f"unknown material {material!r}; the simulator knows: {', '.join(MATERIALS)}",
                              source=source, key=f"{where}.material")
        dims = o.get("dimensions_mm", [0, 0, 0])
        if not isinstance(dims, list) or len(dims) != 3:
            raise EffectError("expected [width, height, depth] in mm", source=source, key=f"{where}.dimensions_mm")
        vs = o.get("velocities_mps")
        if not isinstance(vs, list) or len(vs) < 2:
            raise EffectError("expected a list of at least 2 velocities", source=source, key=f"{where}.velocities_mps")
        objects.append(ObjectInfo(o["id"], str(o.get("name", o["id"])),
                                  _number(o.get("mass_kg"), source, f"{where}.mass_kg", minimum=1e-4, maximum=100.0),
                                  tuple(_number(d, source, f"{where}.dimensions_mm", minimum=0.0, maximum=5000.0)
                                        for d in dims), material))
        velocities[o["id"]] = [_number(v, source, f"{where}.velocities_mps", minimum=SPEC_VELOCITIES[0],
                                       maximum=SPEC_VELOCITIES[1]) for v in vs]
    return objects, velocities, Rig(helmet=helmet, sensor=sensor)
