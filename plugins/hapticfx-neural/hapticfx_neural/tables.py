"""Velocity tables of trained networks: written next to the weights by `hapticfx train` and `hapticfx table`."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Callable

from hapticfx.data.dataset import Dataset
from hapticfx.errors import CheckpointError
from hapticfx.interfaces import Profile
from hapticfx.interpolators.table import DEFAULT_TOLERANCE, VelocityTable, build_table

from . import checkpoint
from .config import POOLED
from .samples import Centres, stack_triples


def network_table(net, meta: dict, banks: list, dataset: str, centres: Centres, *,
                  tolerance: float = DEFAULT_TOLERANCE, progress: Callable[[str], None] | None = None) -> VelocityTable:
    """The velocity table of ``net`` for ``banks`` (one per object), computed in float64.

    ``centres`` finds each neighbour's drop centre, the network's input."""
    from .training import predict_residual

    net64 = copy.deepcopy(net).double().eval()
    wrong = [b.object for b in banks if b.n_samples != meta["n_samples"]]
    if wrong:
        raise CheckpointError(f"the network takes {meta['n_samples']}-sample profiles; "
                              f"{', '.join(wrong)} of dataset {dataset!r} have other lengths")

    def residual(lower, upper, v_lo, v_hi, v, obj):
        rows = [(Profile(a, lo), Profile(b, hi), x, None) for lo, hi, a, b, x in zip(lower, upper, v_lo, v_hi, v)]
        return predict_residual(net64, meta, stack_triples(rows, [obj] * len(v), centres))

    return build_table(banks, residual, interpolator=meta["interpolator"],
                       source=checkpoint.table_source(meta), dataset=dataset,
                       tolerance=tolerance, progress=progress)


def write_table(weights: Path, dataset: Dataset, *, progress: Callable[[str], None] | None = None) -> Path:
    """Build and write the table of the checkpoint ``weights`` for ``dataset``; returns its path."""
    from .training import load_network

    meta = checkpoint.read_meta(weights)
    net, meta = load_network(weights, arch=meta["interpolator"], dataset=dataset.name)
    reducer = meta["dataset"]["reducer"]
    banks = [dataset.bank(obj, reducer) for obj in dataset.objects]
    centres = dataset_centres(meta, dataset, dataset.objects, reducer)
    return network_table(net, meta, banks, dataset.name, centres, progress=progress).save(checkpoint.table_path(weights))


def dataset_centres(meta: dict, dataset: Dataset, objects: list[str], reducer: str) -> Centres:
    """The network's inputs for ``objects`` of ``dataset``: their drop centres, or those centres pooled across
    velocity for a checkpoint trained on pooled inputs (:mod:`.pooled`, fitted again from the drops)."""
    from hapticfx.data.training import recorded_drops, training_data

    if meta["dataset"].get("inputs") == POOLED:
        from .pooled import pooled_centres, pooling

        data = training_data(dataset, reducer, objects)
        return pooled_centres(data, pooling(data), meta["dataset"]["trim"])
    centres = Centres.of(meta)
    for obj in objects:
        centres.add(dataset.bank(obj, reducer), recorded_drops(dataset, obj, reducer))
    return centres
