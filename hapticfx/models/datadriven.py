"""The paper's data-driven model: recorded profiles, interpolated between neighbours."""

from __future__ import annotations

import bisect
import inspect
import threading
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..data.dataset import Dataset, open_dataset
from ..errors import EffectError, HapticfxError, SignalError, preview
from ..interfaces import Impact, Interpolator, Model, Term, Terms
from ..params import BuildContext, doc
from ..signal import Signal


def _interpolator(params, context: BuildContext) -> Interpolator:
    """The effect's interpolator; its options are checked against what its class accepts."""
    try:
        cls = context.components().get("interpolator", params.interpolator).resolve()
    except HapticfxError as exc:
        raise EffectError(str(exc), source=context.source, key="model.interpolator") from None
    accepted = inspect.signature(cls).parameters
    if not any(p.kind is p.VAR_KEYWORD for p in accepted.values()):
        allowed = [n for n, p in accepted.items() if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
        unknown = [k for k in params.interpolator_options if k not in allowed]
        if unknown:
            raise EffectError(f"unknown key {preview(unknown[0])} for interpolator {params.interpolator!r}; allowed: "
                              f"{', '.join(allowed) or 'none'}", source=context.source,
                              key="model.interpolator_options")
    try:
        return cls(**params.interpolator_options)
    except (TypeError, ValueError) as exc:
        raise EffectError(f"{params.interpolator}: {exc}", source=context.source,
                          key="model.interpolator_options") from None


class DataDrivenModel(Model):
    """Profile for a velocity from a dataset's bank and an interpolator.

    A recorded velocity returns the recorded profile exactly; a velocity between
    two recorded ones goes to the interpolator with its two neighbours. Outside
    the recorded range the ``outside`` policy applies: ``scale`` (the nearest
    recorded profile scaled by v / v_edge, so zero velocity is silence),
    ``clamp`` (the nearest recorded profile) or ``refuse`` (an error).
    """

    name = "data-driven"
    units = "g"

    @dataclass(frozen=True)
    class Params:
        dataset: str = field(default="builtin:helmet-drops", metadata=doc("dataset path or builtin:NAME"))
        reducer: str = field(default="max-min", metadata=doc("which bank: the reducer that made it"))
        interpolator: str = field(default="linear", metadata=doc("registered interpolator name"))
        interpolator_options: dict = field(default_factory=dict, metadata=doc("options passed to the interpolator"))
        outside: Literal["scale", "clamp", "refuse"] = field(
            default="scale", metadata=doc("velocities outside the recorded range: scale, clamp or refuse")
        )

    def __init__(self, params: Params, context: BuildContext):
        self.params = params
        self.context = context
        self.dataset: Dataset = open_dataset(params.dataset, relative_to=context.base_dir)
        self.interpolator: Interpolator = _interpolator(params, context)
        self._prepared: dict[str, tuple] = {}  # object -> (bank, its velocities as floats), once prepared
        self._lock = threading.Lock()
        if context.object_id:
            self.bank(context.object_id)  # load and prepare the effect's own object now

    def bank(self, object_id: str):
        return self._bank(object_id)[0]

    def _bank(self, object_id: str) -> tuple:
        found = self._prepared.get(object_id)
        if found is not None:
            return found
        bank = self.dataset.bank(object_id, self.params.reducer)
        with self._lock:
            if object_id not in self._prepared:
                self.interpolator.prepare(bank, dataset=self.dataset, base_dir=self.context.base_dir)
                self._prepared[object_id] = (bank, bank.velocities.tolist())
            return self._prepared[object_id]

    def terms(self, impact: Impact) -> Terms | None:
        """The profile as recorded profiles (and the interpolator's atoms) with weights; None when the
        interpolator's answer between two neighbours is no fixed sum (direct network inference)."""
        return self._terms(impact.object or self.context.object_id, impact.velocity)

    def atoms(self) -> Terms | None:
        object_id = self.context.object_id
        if not object_id:
            return None
        bank = self.bank(object_id)
        items = [self._recorded(bank, i, 1.0) for i in range(len(bank))]
        items += [Term(("interpolator", t.key), 1.0, t.samples) for t in self.interpolator.atoms(bank)]
        return Terms(self.dataset.rate_hz, tuple(items))

    def _recorded(self, bank, i: int, weight: float) -> Term:
        return Term(("bank", bank.object, i), weight, bank.profiles[i])

    def _terms(self, object_id: str, velocity: float) -> Terms | None:
        bank, recorded = self._bank(object_id)
        k = bisect.bisect_right(recorded, velocity)  # recorded[k - 1] <= velocity < recorded[k]
        if k and recorded[k - 1] == velocity:
            return Terms(self.dataset.rate_hz, (self._recorded(bank, k - 1, 1.0),))
        lo, hi = recorded[0], recorded[-1]
        if lo < velocity < hi:
            blend = self.interpolator.blend(bank[k - 1], bank[k], velocity)
            if blend is None:
                return None
            extra = tuple(Term(("interpolator", t.key), t.weight, t.samples) for t in blend.extra)
            return Terms(self.dataset.rate_hz, (self._recorded(bank, k - 1, blend.lower),
                                                self._recorded(bank, k, blend.upper), *extra))
        if self.params.outside == "refuse":
            raise SignalError(
                f"velocity {velocity} m/s is outside the recorded range [{lo}, {hi}] of {object_id!r} "
                "(model.outside is 'refuse')"
            )
        edge = 0 if velocity < lo else len(bank) - 1
        weight = velocity / bank.velocities[edge] if self.params.outside == "scale" else 1.0
        return Terms(self.dataset.rate_hz, (self._recorded(bank, edge, float(weight)),))

    def profile(self, object_id: str, velocity: float) -> np.ndarray:
        terms = self._terms(object_id, velocity)
        if terms is not None:
            return terms.profile().samples
        lower, upper = self.bank(object_id).neighbours(velocity)
        out = np.asarray(self.interpolator.interpolate(lower, upper, velocity), dtype=np.float64)
        if out.shape != lower.samples.shape or not np.all(np.isfinite(out)):
            raise HapticfxError(
                f"interpolator {self.params.interpolator!r} returned an invalid profile "
                f"(shape {out.shape}, finite={bool(np.all(np.isfinite(out)))}) at {velocity} m/s"
            )
        return out

    def render(self, impact: Impact) -> Signal:
        object_id = impact.object or self.context.object_id
        return Signal(self.profile(object_id, impact.velocity), self.dataset.rate_hz)

    def notes(self, impact: Impact) -> list[str]:
        object_id = impact.object or self.context.object_id
        bank = self.bank(object_id)
        lo, hi = float(bank.velocities[0]), float(bank.velocities[-1])
        if lo <= impact.velocity <= hi or self.params.outside == "refuse":
            return []
        how = "scaled by velocity" if self.params.outside == "scale" else "as it is"
        edge = lo if impact.velocity < lo else hi
        return [f"{impact.velocity:g} m/s is outside the recorded {lo:g}-{hi:g} m/s of {object_id}: "
                f"the {edge:g} m/s profile is played {how} (model.outside: {self.params.outside})"]

    def describe(self) -> dict:
        return {
            "model": self.name, "dataset": str(self.dataset.path), "reducer": self.params.reducer,
            "interpolator": self.params.interpolator, **self.interpolator.describe(), "outside": self.params.outside,
        }
