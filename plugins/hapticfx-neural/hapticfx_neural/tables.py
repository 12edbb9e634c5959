"""Velocity tables of trained networks: written next to the weights by `hapticfx train` and `hapticfx table`."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Callable

from hapticfx.data.dataset import Dataset
from hapticfx.errors import CheckpointError
from hapticfx.interpolators.table import DEFAULT_TOLERANCE, VelocityTable, build_table

from . import checkpoint
from .samples import Triples


def network_table(net, meta: dict, banks: list, dataset: str, *, tolerance: float = DEFAULT_TOLERANCE,
                  progress: Callable[[str], None] | None = None) -> VelocityTable:
    """The velocity table of ``net`` for ``banks`` (one per object), computed in float64."""
    from .training import predict_residual

    net64 = copy.deepcopy(net).double().eval()
    wrong = [b.object for b in banks if b.n_samples != meta["n_samples"]]
    if wrong:
        raise CheckpointError(f"the network takes {meta['n_samples']}-sample profiles; "
                              f"{', '.join(wrong)} of dataset {dataset!r} have other lengths")

    def residual(lower, upper, v_lo, v_hi, v, obj):
        return predict_residual(net64, meta, Triples(lower, upper, v_lo, v_hi, v, None, [obj] * len(v)))

    return build_table(banks, residual, interpolator=meta["interpolator"],
                       source={"weights_sha256": meta.get("weights_sha256")}, dataset=dataset,
                       tolerance=tolerance, progress=progress)


def write_table(weights: Path, dataset: Dataset, *, progress: Callable[[str], None] | None = None) -> Path:
    """Build and write the table of the checkpoint ``weights`` for ``dataset``; returns its path."""
    from .training import load_network

    meta = checkpoint.read_meta(weights)
    net, meta = load_network(weights, arch=meta["interpolator"], dataset=dataset.name)
    banks = [dataset.bank(obj, meta["dataset"]["reducer"]) for obj in dataset.objects]
    return network_table(net, meta, banks, dataset.name, progress=progress).save(checkpoint.table_path(weights))
