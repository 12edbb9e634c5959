"""Physical descriptions of falling objects; the paper's four (Table 1) are built in."""

from __future__ import annotations

import re
from dataclasses import dataclass

from .errors import EffectError
from .signal import valid_number


@dataclass(frozen=True)
class ObjectInfo:
    """A falling object: id, display name, mass, size (w x h x d, mm) and material."""

    id: str
    name: str
    mass_kg: float
    dimensions_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    material: str = "unknown"

    def __post_init__(self):
        valid_number(self.mass_kg, name=f"object {self.id!r} mass_kg", minimum=1e-6, maximum=1e4)


_OBJECT_ID = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,63}")


def valid_object_id(object_id) -> bool:
    """Whether ``object_id`` can name an object in a dataset (it names files there: no paths, no dotfiles)."""
    return isinstance(object_id, str) and _OBJECT_ID.fullmatch(object_id) is not None


PAPER_OBJECTS: dict[str, ObjectInfo] = {
    o.id: o
    for o in (
        ObjectInfo("plastic-frame", "Plastic frame", 0.035, (53.4, 81.9, 44.7), "plastic"),
        ObjectInfo("concrete-brick", "Concrete brick", 0.069, (36.5, 48.3, 14.6), "concrete"),
        ObjectInfo("wood-beam", "Piece of wood beam", 0.150, (58.2, 98.3, 35.6), "wood"),
        ObjectInfo("steel-plate", "Steel plate", 0.200, (100.0, 100.0, 4.8), "steel"),
    )
}


def builtin_object(object_id: str, *, source: str | None = None, key: str = "object") -> ObjectInfo:
    """The built-in object ``object_id``, or an :class:`EffectError` listing the known ones."""
    try:
        return PAPER_OBJECTS[object_id]
    except KeyError:
        raise EffectError(
            f"unknown object {object_id!r}; built-in objects: {', '.join(PAPER_OBJECTS)} "
            "(or describe it: {id, mass_kg, ...})",
            source=source,
            key=key,
        ) from None


def known_object(context, object_id: str) -> ObjectInfo:
    """The object an impact names, for a model built for ``context``'s effect: the effect's own object
    (also when ``object_id`` is empty) or a built-in one; an :class:`EffectError` for any other, whose
    mass the model cannot know."""
    own = context.object_info
    if not object_id or (own is not None and object_id == own.id):
        if own is None:
            raise EffectError("the effect describes no object", source=context.source, key="object")
        return own
    if object_id in PAPER_OBJECTS:
        return PAPER_OBJECTS[object_id]
    raise EffectError(
        f"object {object_id!r} is neither the effect's object ({own.id if own else 'none'}) nor a built-in one "
        f"({', '.join(PAPER_OBJECTS)}): its mass is unknown; describe it in an effect, or set model.mass_kg",
        source=context.source, key="object",
    )
