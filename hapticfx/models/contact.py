"""The ``contact`` model: a simulated physical impact with the helmet's residual vibration."""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import EffectError
from ..interfaces import Impact, Model
from ..objects import PAPER_OBJECTS, ObjectInfo, known_object
from ..params import BuildContext, doc
from ..signal import Signal


FINE_RATE_HZ = 20000.0  # the contact and the helmet's modes are resolved on this grid, then averaged


class ContactModel(Model):
    """The drop-rig physics (:mod:`hapticfx.droprig.contact`) rendered as one impact profile in g.

    The object meets the helmet at the impact's velocity; the Hunt-Crossley
    contact (every contact until they part for good) drives the helmet's
    bounce, rocking and shell modes; the 3-axis acceleration at the sensor
    position (no gravity, no sensor noise or clipping) is reduced to 1D with
    ``reducer`` and sampled at ``rate_hz`` by averaging over each sample
    interval. The profile starts ``pre_ms`` before the contact. Material,
    stiffness and damping default to the effect object's material.

    What is rendered is the collision: the object is not weighed down by
    gravity (the helmet still rests on its support). Its weight would add a
    static load, which no actuator here can render, and would turn a slow
    touch into a thump; without it the response fades to silence as the
    velocity goes to 0, and a hit along any direction (a bat, a kick) is
    rendered the same way as a fall. The recorded drops of the built-in
    dataset (:mod:`hapticfx.droprig.synth`) do include gravity.
    """

    name = "contact"
    units = "g"
    CACHE = 128

    @dataclass(frozen=True)
    class Params:
        material: str | None = field(default=None, metadata=doc(
            "contact material: plastic, concrete, wood, steel (default: the object's)"))
        stiffness: float | None = field(default=None, metadata=doc(
            "Hunt-Crossley stiffness k (N/m^1.5); default from the material", min=1e3, max=1e10))
        damping: float | None = field(default=None, metadata=doc(
            "Hunt-Crossley damping alpha (s/m); default from the material", min=0.0, max=10.0))
        tilt_deg: float = field(default=0.0, metadata=doc("tilt of the object at contact (degrees)", min=-60.0, max=60.0))
        offset_mm: float = field(default=0.0, metadata=doc("contact point offset from the crown (mm)", min=-80.0, max=80.0))
        helmet_mass_kg: float = field(default=3.5, metadata=doc("effective mass of the helmet on the floor (kg)", min=0.1, max=100.0))
        mass_kg: float | None = field(default=None, metadata=doc("object mass; default: the effect's object", min=1e-3, max=1e4))
        reducer: str = field(default="max-min", metadata=doc("3-axis to 1D reducer (a registered reducer)"))
        duration_ms: float = field(default=500.0, metadata=doc("length of the rendered profile (ms)", min=10.0, max=5000.0))
        pre_ms: float = field(default=10.0, metadata=doc("silence before the first contact (ms)", min=0.0, max=1000.0))
        rate_hz: float = field(default=1000.0, metadata=doc("sample rate of the profile (Hz)", min=100.0, max=96000.0))

    def __init__(self, params: Params, context: BuildContext):
        import scipy.integrate  # noqa: F401 -- loaded when the effect is built, not on its first impact (~1 s)
        import scipy.signal  # noqa: F401

        from ..droprig.contact import MATERIALS
        from ..registry import get_registry

        self.params = params
        self.context = context
        if params.material is not None and params.material not in MATERIALS:
            raise EffectError(f"unknown material {params.material!r}; known: {', '.join(MATERIALS)}",
                              source=context.source, key="model.material")
        if params.pre_ms >= params.duration_ms:
            raise EffectError(f"pre_ms {params.pre_ms} must be shorter than duration_ms {params.duration_ms}",
                              source=context.source, key="model.pre_ms")
        if params.mass_kg is None and context.object_info is None:
            raise EffectError("the contact model needs an object: describe it with mass_kg (and dimensions_mm), "
                              "or set model.mass_kg", source=context.source, key="model")
        self.reducer = get_registry().create("reducer", params.reducer)
        self._cache: OrderedDict[tuple[str, float], np.ndarray] = OrderedDict()
        self._lock = threading.Lock()

    def object_for(self, object_id: str) -> ObjectInfo:
        p = self.params
        if self.context.object_info is None or (p.mass_kg is not None and object_id not in PAPER_OBJECTS
                                                and object_id != self.context.object_info.id):
            info = ObjectInfo(object_id or "object", object_id or "object", p.mass_kg)
        else:
            info = known_object(self.context, object_id)
        return replace(info, mass_kg=p.mass_kg if p.mass_kg is not None else info.mass_kg,
                       material=p.material or info.material)

    def scene(self, info: ObjectInfo, velocity: float):
        """The contact scene of one impact and its grid: ``(scene, fine_rate_hz, n_fine, lead)``.

        The scene's state is sampled ``n_fine - lead`` times at ``fine_rate_hz``
        from the first contact; ``lead`` fine samples of silence come before it.
        """
        from ..droprig.contact import material
        from ..droprig.helmet import Helmet
        from ..droprig.synth import Drop, scene_for

        p = self.params
        n = max(1, int(round(p.duration_ms * p.rate_hz / 1000.0)))
        over = max(1, math.ceil(FINE_RATE_HZ / p.rate_hz))
        fine_rate = p.rate_hz * over
        mat = material(info.material)
        drop = Drop(velocity, tilt=math.radians(p.tilt_deg), offset=p.offset_mm * 1e-3,
                    stiffness=p.stiffness if p.stiffness is not None else mat.stiffness,
                    damping=p.damping if p.damping is not None else mat.damping)
        scene = replace(scene_for(info, drop, Helmet(mass=p.helmet_mass_kg)), gap=0.0, gravity=0.0)
        return scene, fine_rate, n * over, min(n * over, int(round(p.pre_ms / 1000.0 * fine_rate)))

    def _profile(self, info: ObjectInfo, velocity: float) -> np.ndarray:
        from ..droprig.hertz import G

        p = self.params
        n = max(1, int(round(p.duration_ms * p.rate_hz / 1000.0)))
        if velocity == 0.0:
            return np.zeros(n)
        scene, fine_rate, n_fine, lead = self.scene(info, velocity)
        acc = np.zeros((n_fine, 3))
        if lead < n_fine:
            states = scene.sample(n_fine - lead, fine_rate)
            acc[lead:] = scene.helmet.sensor_acceleration(states, fine_rate)
        block = acc.reshape(n, n_fine // n, 3).mean(axis=1)
        return self.reducer.reduce(block / G)

    def render(self, impact: Impact) -> Signal:
        info = self.object_for(impact.object)
        key = (info.id, float(impact.velocity))
        with self._lock:
            cached = self._cache.get(key)
            if cached is not None:
                self._cache.move_to_end(key)
        if cached is None:
            cached = self._profile(info, float(impact.velocity))
            with self._lock:
                self._cache[key] = cached
                while len(self._cache) > self.CACHE:
                    self._cache.popitem(last=False)
        return Signal(cached, self.params.rate_hz)

    def describe(self) -> dict:
        from ..droprig.contact import material

        p = self.params
        info = self.context.object_info
        mat = material(p.material or (info.material if info else "unknown"))
        return {"model": self.name, "material": mat.name,
                "stiffness": p.stiffness if p.stiffness is not None else mat.stiffness,
                "damping": p.damping if p.damping is not None else mat.damping,
                "reducer": p.reducer, "rate_hz": p.rate_hz}
