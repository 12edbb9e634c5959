"""Pooled inputs (``inputs: pooled``): the neighbours' centres as ``ensemble-warp`` pools them across velocity.

With few drops a velocity's centre is mostly its own sampling noise; ``ensemble-warp`` shrinks or smooths each
object's centres across the recorded velocities, each object as its training velocities left out one at a time
chose (:class:`hapticfx.interpolators.ensemble_warp.Fit`). With ``inputs: pooled`` the network reads those pooled
centres instead of the raw ones. A training triple's inputs are pooled without its target velocity (what its
neighbours would be had the target not been recorded), so that the network is not taught from inputs that already
hold its target's drops; at inference they are pooled over every recorded velocity. The pooling is refitted from
the dataset where a table is built or a checkpoint is served directly: it depends on the drops alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from hapticfx.interfaces import TrainingData

from .samples import Centres, DropTriples


def pooling(data: TrainingData):
    """What pools ``data``'s centres: ``ensemble-warp``'s fit (numpy; texture 0, it is not used here)."""
    from hapticfx.interpolators.ensemble_warp import Fit

    return Fit(data, texture=0.0)


def pooled_triples(data: TrainingData, triples: DropTriples, fit, prefix: str = "") -> DropTriples:
    """``triples`` (of ``data``'s objects, named ``prefix + object``) with their inputs pooled by ``fit`` without
    each triple's target velocity."""
    without: dict[tuple[str, int], np.ndarray] = {}
    lc, uc = [], []
    for n, name in enumerate(triples.objects):
        obj = name[len(prefix):]
        bank = data.banks[obj]
        i, lo, hi = (bank.index_of(float(x)) for x in (triples.v[n], triples.v_lo[n], triples.v_hi[n]))
        if (obj, i) not in without:
            without[(obj, i)] = fit.centres_without(obj, i)
        lc.append(without[(obj, i)][lo])
        uc.append(without[(obj, i)][hi - 1])  # above i, every kept velocity moves down one
    return dataclasses.replace(triples, given=(np.stack(lc), np.stack(uc)))


def pooled_centres(data: TrainingData, fit, trim: float) -> Centres:
    """The inference inputs: every recorded velocity's centre pooled by ``fit`` over all of them."""
    centres = Centres(trim)
    for obj, bank in data.banks.items():
        centres.set(bank, fit.centres[obj])
    return centres
