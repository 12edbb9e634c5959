"""The paper's physics baseline (Eqs. 9-11): a square pulse scaled by kinetic energy."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import EffectError
from ..interfaces import Impact, Model, Term, Terms
from ..objects import known_object
from ..params import BuildContext, doc
from ..signal import Signal

# The steel plate (200 g) at the highest recorded velocity (5.24 m/s): the
# strongest impact of the paper's set maps to full scale by default.
DEFAULT_KE_MAX_J = 0.5 * 0.200 * 5.24**2


class KineticEnergyModel(Model):
    """``amplitude = clip(0.5 m v^2 / KE_max, 0, 1)`` held for ``pulse_ms``, then silence.

    The output is a fraction of the actuator's full range, not an acceleration.
    """

    name = "kinetic-energy"
    units = "fraction"

    @dataclass(frozen=True)
    class Params:
        ke_max_j: float = field(default=DEFAULT_KE_MAX_J, metadata=doc("kinetic energy mapped to full scale (J)", min=1e-9))
        pulse_ms: float = field(default=30.0, metadata=doc("square pulse width b (ms)", min=0.0, max=10000.0))
        duration_ms: float = field(default=500.0, metadata=doc("length of the rendered signal (ms)", min=1.0, max=60000.0))
        rate_hz: float = field(default=1000.0, metadata=doc("sample rate of the rendered profile (Hz)", min=1.0, max=1e6))
        mass_kg: float | None = field(default=None, metadata=doc("object mass; default: the effect's object", min=1e-6, max=1e4))

    def __init__(self, params: Params, context: BuildContext):
        self.params = params
        self.context = context
        if params.pulse_ms > params.duration_ms:
            raise EffectError(
                f"pulse_ms {params.pulse_ms} is longer than duration_ms {params.duration_ms}",
                source=context.source, key="model.pulse_ms",
            )
        n = max(1, int(round(params.duration_ms * params.rate_hz / 1000.0)))
        width = int(round(params.pulse_ms * params.rate_hz / 1000.0))
        if width == 0:
            raise EffectError(f"pulse_ms {params.pulse_ms:g} is under half a sample at rate_hz {params.rate_hz:g}: "
                              f"the pulse would be silent; give more than {500.0 / params.rate_hz:g} ms",
                              source=context.source, key="model.pulse_ms")
        if 1 + width > n:  # sample 0 (t = 0) is silent: the pulse is the `width` samples after it
            raise EffectError(f"pulse_ms {params.pulse_ms:g} and the silent first sample (t = 0) do not fit in "
                              f"duration_ms {params.duration_ms:g} at rate_hz {params.rate_hz:g}: give duration_ms at "
                              f"least {(1 + width) * 1000.0 / params.rate_hz:g}",
                              source=context.source, key="model.duration_ms")
        self._pulse = np.zeros(n)
        self._pulse[1 : 1 + width] = 1.0  # sample 0 is t = 0
        self._pulse.setflags(write=False)
        if params.mass_kg is None and context.object_info is None:
            raise EffectError(
                "the kinetic-energy model needs a mass: describe the object with mass_kg, or set model.mass_kg",
                source=context.source, key="model",
            )

    def mass_for(self, object_id: str) -> float:
        if self.params.mass_kg is not None:
            return self.params.mass_kg
        return known_object(self.context, object_id).mass_kg

    def amplitude(self, velocity: float, mass_kg: float) -> float:
        """Eqs. 9-10, clipped to [0, 1]."""
        ke = 0.5 * mass_kg * velocity * velocity
        return float(np.clip(ke / self.params.ke_max_j, 0.0, 1.0))

    def render(self, impact: Impact) -> Signal:
        return self.terms(impact).profile()

    def terms(self, impact: Impact) -> Terms:
        """Eq. 11: ``f(t) = A`` for ``0 < t < b``: the unit pulse with weight ``A``."""
        return Terms(self.params.rate_hz, (Term("pulse", self.amplitude(impact.velocity, self.mass_for(impact.object)),
                                                 self._pulse),))

    def atoms(self) -> Terms:
        return Terms(self.params.rate_hz, (Term("pulse", 1.0, self._pulse),))

    def describe(self) -> dict:
        return {"model": self.name, "ke_max_j": self.params.ke_max_j, "pulse_ms": self.params.pulse_ms}
