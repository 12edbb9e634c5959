"""Building :class:`~hapticfx.interfaces.TrainingData` from a dataset, with velocities held out."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import DatasetError
from ..interfaces import TrainingData
from .dataset import Dataset

if TYPE_CHECKING:
    from ..registry import Registry


def recorded_drops(dataset: Dataset, object_id: str, reducer: str, *,
                   registry: Registry | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """Every drop of one object, preprocessed and reduced like its bank: ``velocities (V,)``, ``(V, D, N)``;
    the reducer from ``registry`` (default: the process-wide one).

    None when the dataset keeps no raw recordings of the object (a bank-only dataset).
    """
    from ..processing.reducers import reduce_checked
    from ..registry import get_registry

    if not (dataset.path / "raw" / f"{object_id}.npz").is_file():
        return None
    velocities, windows = dataset.windows(object_id)
    return velocities, reduce_checked((registry or get_registry()).create("reducer", reducer), reducer, windows,
                                      source=str(dataset.path), label=f"object {object_id!r}")


def training_data(dataset: Dataset, reducer: str, objects: list[str] | None = None, *,
                  holdout: dict[str, list[float]] | None = None, targets: dict[str, list[float]] | None = None,
                  drops: bool = True) -> TrainingData:
    """The banks (and drops) of ``objects`` with the ``holdout`` velocities of each object removed from both."""
    objects = objects or dataset.objects
    holdout = holdout or {}
    banks, all_drops = {}, {}
    for obj in objects:
        bank = dataset.bank(obj, reducer)
        gone = [float(v) for v in holdout.get(obj, [])]
        for v in gone:
            if bank.index_of(v) is None:
                raise DatasetError(f"{v} m/s is not recorded for {obj!r}; recorded: "
                                   f"{', '.join(f'{x:g}' for x in bank.velocities)}")
            bank = bank.without(v)
        banks[obj] = bank
        found = recorded_drops(dataset, obj, reducer) if drops else None
        if found is not None:
            velocities, reduced = found
            keep = ~np.isin(velocities, gone)
            all_drops[obj] = (velocities[keep], reduced[keep])
    return TrainingData(banks, reducer, dataset.name, all_drops, targets)
