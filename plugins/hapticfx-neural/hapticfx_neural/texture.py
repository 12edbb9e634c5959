"""How much of the recorded neighbours' fine detail a trained network's profiles keep, chosen on its validation
targets.

The network predicts a velocity's drop centre; served in the core's residual form, its profile is the blend of
the neighbours' representatives drawn toward that centre, and keeps a share of the representatives' detail above
100 Hz (:mod:`hapticfx.interpolators.texture`, as ``ensemble-warp`` does). With ``texture: choose`` the share is
chosen after training on the validation targets, pools that training never fitted: each validation triple is
predicted from its neighbours' full centres and scored against every drop of its target velocity, as
:func:`hapticfx.interpolators.texture.choose` scores ``ensemble-warp``'s left-out velocities.
"""

from __future__ import annotations

import numpy as np

from hapticfx.interpolators.residual import weight
from hapticfx.interpolators.texture import Target, choose

from .config import CHOOSE
from .samples import DropTriples, centre_of


def validation_targets(correction, data: DropTriples) -> list[Target]:
    """The texture targets of ``data`` (the validation triples, with their representatives), given
    ``correction(triples) -> (n, N)``, the network's correction for their centres."""
    t = data.centres()
    t.lower = np.stack([data.reps[k] for k in data.lo])
    t.upper = np.stack([data.reps[k] for k in data.hi])
    w = weight(t.v_lo, t.v_hi, t.v)
    blend = (1.0 - w[:, None]) * t.lower + w[:, None] * t.upper
    diff = centre_of(t, correction(t)) - blend
    return [Target(float(w[i]), blend[i], diff[i], data.pools[k], data.pools[k].mean(axis=0), data.reps[k],
                   float(data.rate_hz)) for i, k in enumerate(data.tgt)]


def chosen_texture(setting, correction, validation: DropTriples) -> dict | None:
    """A checkpoint's ``texture`` record: the share ``setting`` fixes, or (:data:`~.config.CHOOSE`) the one chosen
    on ``validation``, with every share's mean scores there. None where none is kept: a fixed share 0, or nothing
    to choose on (no validation targets, or no representatives)."""
    if setting != CHOOSE:
        if not setting:
            return None
        if validation.rate_hz is None:
            raise ValueError("a fixed texture needs the banks' rate (DropTriples.rate_hz)")
        return {"share": float(setting), "chosen_on": "fixed", "rate_hz": float(validation.rate_hz)}
    if not len(validation) or validation.reps is None or validation.rate_hz is None:
        return None
    (share, _), scores = choose(validation_targets(correction, validation))
    return {"share": float(share), "chosen_on": f"{len(validation)} validation triples",
            "rate_hz": float(validation.rate_hz), "scores": scores}
