"""The ``contact`` model: a simulated physical impact with the helmet's residual vibration."""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from ..errors import EffectError, SignalError
from ..interfaces import Impact, Model
from ..objects import PAPER_OBJECTS, ObjectInfo, known_object
from ..params import BuildContext, doc
from ..signal import Signal

if TYPE_CHECKING:
    from .physics_table import PhysicsTable


FINE_RATE_HZ = 20000.0  # the contact and the helmet's modes are resolved on this grid, then averaged
RTOL = 1e-10  # of the integration, for tables and direct renders alike: at 1e-9 the solver's noise where a contact
# ends reached 5e-7 of the peak (the wheel near 0.26 m/s), too rough for a table within 1e-6; at 1e-10 it is 7e-8


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
        receiver: str = field(default="helmet", metadata=doc(
            "the struck body: helmet, tabletop, bat-handle, car-seat, boot (docs/families.md)"))
        receiver_mass_kg: float | None = field(default=None, metadata=doc(
            "effective mass of the struck body (kg); default: the receiver's own", min=0.1, max=1000.0))
        felt: Literal["sensor", "receiver", "striker"] = field(default="sensor", metadata=doc(
            "what is rendered: sensor (the receiver's 3-axis sensor, reduced with `reducer`), receiver (the struck "
            "body's acceleration along the impact, where it is held) or striker (the striking body's, e.g. a "
            "fingertip or stylus that taps)"))
        mass_kg: float | None = field(default=None, metadata=doc("object mass; default: the effect's object", min=1e-6, max=1e4))
        hold_n: float = field(default=0.0, metadata=doc(
            "force pressing the striker onto the receiver (N): a held stylus or fingertip stays in contact and rings "
            "on it; what the press alone does (velocity 0) is subtracted", min=0.0, max=1000.0))
        reducer: str = field(default="max-min", metadata=doc("3-axis to 1D reducer (a registered reducer; felt: sensor)"))
        duration_ms: float = field(default=500.0, metadata=doc("length of the rendered profile (ms)", min=10.0, max=5000.0))
        pre_ms: float = field(default=10.0, metadata=doc("silence before the first contact (ms)", min=0.0, max=1000.0))
        rate_hz: float = field(default=1000.0, metadata=doc("sample rate of the profile (Hz)", min=100.0, max=96000.0))
        max_velocity_mps: float = field(default=10.0, metadata=doc(
            "highest impact velocity rendered (m/s); a faster impact is an error", min=1e-3, max=100.0))
        table: bool = field(default=True, metadata=doc(
            "serve impacts from a velocity table built once (true), or integrate the contact at every impact"))

    def __init__(self, params: Params, context: BuildContext):
        if not params.table:  # every impact integrates: load the solver now, not on the first impact (~1 s);
            import scipy.integrate  # noqa: F401 -- a table is read without it, and built (once) with it
            import scipy.signal  # noqa: F401

        from ..droprig.contact import MATERIALS
        from ..droprig.family import Strike
        from ..droprig.receiver import RECEIVERS

        self.params = params
        self.context = context
        if params.material is not None and params.material not in MATERIALS:
            raise EffectError(f"unknown material {params.material!r}; known: {', '.join(MATERIALS)}",
                              source=context.source, key="model.material")
        if params.receiver not in RECEIVERS:
            raise EffectError(f"unknown receiver {params.receiver!r}; shipped: {', '.join(RECEIVERS)}",
                              source=context.source, key="model.receiver")
        if (params.duration_ms - params.pre_ms) * params.rate_hz / 1000.0 < 2:
            raise EffectError(f"pre_ms {params.pre_ms:g} leaves less than two samples of duration_ms "
                              f"{params.duration_ms:g} at rate_hz {params.rate_hz:g} for the impact: it would render "
                              "silence", source=context.source, key="model.pre_ms")
        if params.mass_kg is None and context.object_info is None:
            raise EffectError("the contact model needs an object: describe it with mass_kg (and dimensions_mm), "
                              "or set model.mass_kg", source=context.source, key="model")
        self.reducer = context.components().create("reducer", params.reducer)
        self._cache: OrderedDict[tuple[str, float], np.ndarray] = OrderedDict()
        self._lock = threading.Lock()
        self._tables: dict[str, "PhysicsTable"] = {}
        self._press: dict[str, np.ndarray] = {}  # per object: what the hold force alone does
        self.strike = Strike(stiffness=params.stiffness, damping=params.damping, tilt=math.radians(params.tilt_deg),
                             offset=params.offset_mm * 1e-3, hold_n=params.hold_n, felt=params.felt)

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
        p = self.params
        n = self.n_samples
        over = max(1, math.ceil(FINE_RATE_HZ / p.rate_hz))
        fine_rate = p.rate_hz * over
        scene = self.strike.scene(info, self.strike.centre(info, velocity), self.receiver_model())
        return scene, fine_rate, n * over, min(n * over, int(round(p.pre_ms / 1000.0 * fine_rate)))

    def receiver_model(self):
        """The struck body: the named receiver, with its effective mass overridden where the effect says so."""
        from ..droprig.receiver import named_receiver

        r = named_receiver(self.params.receiver)
        return r if self.params.receiver_mass_kg is None else replace(r, mass=self.params.receiver_mass_kg)

    @property
    def n_samples(self) -> int:
        p = self.params
        return max(1, int(round(p.duration_ms * p.rate_hz / 1000.0)))

    def _raw(self, info: ObjectInfo, velocity: float) -> np.ndarray:
        """What is felt at ``velocity`` by integrating the contact, in g: ``(N,)``, or ``(N * 3,)`` for the
        3-axis sensor (time-major) before its reducer; with a hold force, less what the press alone does."""
        from ..droprig.hertz import G

        p = self.params
        n, axes = self.n_samples, 3 if p.felt == "sensor" else 1
        if velocity == 0.0:  # no impact (with a hold force: the press less itself)
            return np.zeros(n * axes)
        scene, fine_rate, n_fine, lead = self.scene(info, velocity)
        acc = np.zeros((n_fine, 3))
        if lead < n_fine:
            receiver, press = scene.helmet, None
            if p.hold_n > 0.0:
                press = self._press.get(info.id)
                if press is None:
                    press = self._press[info.id] = self.strike.response(
                        info, self.strike.centre(info, 0.0), receiver, n_fine - lead, fine_rate, rtol=RTOL)
            acc[lead:] = self.strike.response(info, self.strike.centre(info, velocity), receiver, n_fine - lead,
                                              fine_rate, rtol=RTOL, press=press)
        acc = acc if p.felt == "sensor" else acc[:, 2:]
        return (acc.reshape(n, n_fine // n, axes).mean(axis=1) / G).reshape(-1)

    def _finish(self, raw: np.ndarray) -> np.ndarray:
        return self.reducer.reduce(raw.reshape(-1, 3)) if self.params.felt == "sensor" else raw

    def _profile(self, info: ObjectInfo, velocity: float) -> np.ndarray:
        """The profile at ``velocity`` by integrating the contact."""
        return self._finish(self._raw(info, velocity))

    def spec(self, info: ObjectInfo) -> dict:
        """Everything a profile of ``info`` depends on, for the table's hash."""
        p = self.params
        receiver = asdict(self.receiver_model())
        return {"model": self.name, "params": {k: v for k, v in asdict(p).items() if k not in ("table", "reducer")},
                "receiver": receiver, "object": asdict(info), "fine_rate_hz": FINE_RATE_HZ, "rtol": RTOL}

    def table_for(self, info: ObjectInfo, *, progress=None) -> "PhysicsTable":
        """The velocity table of ``info`` (loaded, or built and cached at first use; ``progress(message)``)."""
        from .physics_table import load_or_build

        table = self._tables.get(info.id)
        if table is None:
            p = self.params
            table = load_or_build(info.id, lambda v: self._raw(info, v), v_max=p.max_velocity_mps,
                                  rate_hz=p.rate_hz, spec=self.spec(info), reducer=f"felt:{p.felt}",
                                  shipped=self.context.base_dir / "tables", progress=progress)
            self._tables[info.id] = table
        return table

    # No terms(): a table's profile is one small matrix product at the profile's rate, then shaped once per impact;
    # shaping each of a table's hundreds of rows ahead at the device's rate would hold tens of MB per effect.
    def render(self, impact: Impact) -> Signal:
        self._check_range(impact.velocity)
        info = self.object_for(impact.object)
        if self.params.table:
            table = self.table_for(info)
            if table.served_at(impact.velocity):  # else a range the table could not follow: integrated, below
                return Signal(self._finish(table.profile(impact.velocity)), self.params.rate_hz)
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

    def _check_range(self, velocity: float) -> None:
        if velocity > self.params.max_velocity_mps:
            raise SignalError(f"velocity {velocity:g} m/s is past this effect's range (0 to "
                              f"{self.params.max_velocity_mps:g} m/s); raise model.max_velocity_mps to render it",
                              source=self.context.source)

    def describe(self) -> dict:
        from ..droprig.contact import material

        p = self.params
        info = self.context.object_info
        mat = material(p.material or (info.material if info else "unknown"))
        return {"model": self.name, "material": mat.name,
                "stiffness": p.stiffness if p.stiffness is not None else mat.stiffness,
                "damping": p.damping if p.damping is not None else mat.damping,
                "reducer": p.reducer, "rate_hz": p.rate_hz, "max_velocity_mps": p.max_velocity_mps,
                **({"served_from": {k: t.describe() for k, t in self._tables.items()}} if self._tables else
                   {"served_from": "direct integration" if not p.table else "a table built at first use"})}
