"""Training runs over a dataset: which banks, which targets, which velocities are held out."""

from __future__ import annotations

from pathlib import Path

from hapticfx.data.dataset import open_dataset
from hapticfx.errors import DatasetError

from .config import TrainConfig
from .samples import Triples, concat, triples_from_bank


def reduced_bank(bank, holdout: list[float]):
    """``bank`` without the held-out velocities (they are then neither targets nor inputs)."""
    for v in holdout:
        if bank.index_of(v) is not None:
            bank = bank.without(v)
    return bank


def dataset_triples(dataset, reducer: str, objects: list[str], *, train: list[float] | None,
                    holdout: list[float]) -> tuple[Triples, dict]:
    """Training triples of every object: targets ``train`` (default: every interior velocity) of the reduced bank."""
    parts, targets = [], {}
    for obj in objects:
        bank = reduced_bank(dataset.bank(obj, reducer), holdout)
        interior = [float(v) for v in bank.velocities[1:-1]]
        chosen = interior if train is None else [v for v in train if v not in holdout]
        if not chosen:
            raise DatasetError(f"no training targets for {obj!r}: interior velocities are {interior}")
        parts.append(triples_from_bank(bank, chosen))
        targets[obj] = chosen
    return concat(parts), targets


def dataset_ref(dataset) -> str:
    """How a checkpoint names its dataset so that `hapticfx table` can open it again."""
    from hapticfx.data.dataset import BUILTIN_DIR, BUILTIN_PREFIX

    return BUILTIN_PREFIX + dataset.path.name if dataset.path.parent == BUILTIN_DIR else str(dataset.path.resolve())


def train_from_config(cfg: TrainConfig, *, resume: bool = False, progress: bool = True) -> tuple[dict, Path]:
    """Train the configured interpolator and write its velocity table; returns its metadata and weights' path."""
    from .tables import write_table
    from .training import train_network

    dataset = open_dataset(cfg.dataset, relative_to=Path(cfg.source).parent if cfg.source != "<config>" else None)
    objects = cfg.objects or dataset.objects
    data, targets = dataset_triples(dataset, cfg.reducer, objects, train=cfg.train_velocities,
                                    holdout=cfg.holdout_velocities)
    out = cfg.out_dir(dataset.name)
    meta_ds = {"name": dataset.name, "ref": dataset_ref(dataset), "reducer": cfg.reducer, "objects": list(objects),
               "targets": targets, "holdout": list(cfg.holdout_velocities)}
    _, meta = train_network(cfg.interpolator, cfg.model, cfg.training, data, dataset_meta=meta_ds, out=out,
                            resume=resume, progress=progress, label=f"train {cfg.interpolator}")
    weights = out / "model.safetensors"
    write_table(weights, dataset)
    return meta, weights
