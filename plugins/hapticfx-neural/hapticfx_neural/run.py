"""Training runs over datasets: which banks and drops, which targets, which velocities are held out."""

from __future__ import annotations

from pathlib import Path

from hapticfx.data.dataset import open_dataset
from hapticfx.errors import DatasetError, EffectError
from hapticfx.progress import say

from .config import POOLED, TrainConfig
from .samples import DropTriples, concat, drop_triples, object_pools


def triples_of(data, *, gaps: list[int], trim: float = 0.0, targets: dict[str, list[float]] | None = None,
               prefix: str = "") -> tuple[DropTriples, dict]:
    """Triples of every object of ``data`` (:class:`~hapticfx.interfaces.TrainingData`) from all its drops.

    Targets: ``targets[obj]`` (else ``data.targets``, else every interior recorded velocity).
    """
    rows, reps, rates, chosen = [], [], set(), {}
    for obj, bank in data.banks.items():
        interior = [float(v) for v in bank.velocities[1:-1]]
        wanted = (targets or data.targets or {}).get(obj)
        picked = interior if wanted is None else [float(v) for v in wanted if bank.index_of(v) is not None]
        if any(bank.index_of(v) in (0, len(bank) - 1) for v in picked):
            raise DatasetError(f"the lowest and highest recorded velocities of {obj!r} have no neighbour on one "
                               "side and cannot be targets")
        if not picked:
            continue
        rows.append((prefix + obj, bank.velocities, object_pools(bank, data.drops.get(obj)), picked))
        reps.append(bank.profiles)
        rates.add(float(bank.rate_hz))
        chosen[obj] = picked
    if not rows:
        raise DatasetError(f"no training targets in dataset {data.dataset!r}: a target needs a recorded velocity "
                           "on each side")
    if len(rates) > 1:
        raise DatasetError(f"dataset {data.dataset!r} holds banks at different rates ({', '.join(map(str, sorted(rates)))} "
                           "Hz); one network takes one rate")
    return drop_triples(rows, gaps=gaps, trim=trim, reps=reps, rate_hz=rates.pop()), chosen


def dataset_ref(dataset) -> str:
    """How a checkpoint names its dataset so that `hapticfx table` can open it again."""
    from hapticfx.data.dataset import BUILTIN_DIR, BUILTIN_PREFIX

    return BUILTIN_PREFIX + dataset.path.name if dataset.path.parent == BUILTIN_DIR else str(dataset.path.resolve())


def config_triples(cfg: TrainConfig) -> tuple[list, DropTriples, dict]:
    """The datasets of ``cfg``, their triples and what the checkpoint records about them."""
    from hapticfx.data.training import training_data

    base = Path(cfg.source).parent if cfg.source != "<config>" else None
    datasets = [open_dataset(ref, relative_to=base) for ref in cfg.datasets]
    parts, targets, held, trained = [], {}, set(), set()
    for ds in datasets:
        objects = cfg.objects or ds.objects
        unknown = [o for o in objects if o not in ds.objects]
        if unknown:
            raise EffectError(f"dataset {ds.name!r} has no object {unknown[0]!r}; it has: {', '.join(ds.objects)}",
                              source=cfg.source, key="objects")
        if ds.n_samples % int(cfg.model["steps"]):
            raise EffectError(f"{ds.name}'s profiles of {ds.n_samples} samples cannot be cut into "
                              f"{cfg.model['steps']} equal steps", source=cfg.source, key="model.steps")
        if cfg.train_velocities is not None:
            here = {v for o in objects for v in cfg.train_velocities if ds.bank(o, cfg.reducer).index_of(v) is not None}
            if not here:
                raise EffectError(f"none of {', '.join(f'{v:g}' for v in cfg.train_velocities)} m/s is a recorded "
                                  f"velocity of {ds.name} (`hapticfx data info` lists them)", source=cfg.source,
                                  key="train_velocities")
            trained |= here
        holdout = {o: [v for v in cfg.holdout_velocities if ds.bank(o, cfg.reducer).index_of(v) is not None]
                   for o in objects}
        held.update(v for vs in holdout.values() for v in vs)
        for o, vs in holdout.items():
            if len(vs) == len(ds.bank(o, cfg.reducer).velocities):
                raise EffectError(f"holds out every recorded velocity of object {o!r} of {ds.name}: nothing is "
                                  "left to train on", source=cfg.source, key="holdout_velocities")
        data = training_data(ds, cfg.reducer, objects, holdout=holdout)
        wanted = None if cfg.train_velocities is None else {o: cfg.train_velocities for o in objects}
        prefix = f"{ds.name}/" if len(datasets) > 1 else ""
        part, chosen = triples_of(data, gaps=cfg.gaps, trim=cfg.trim, targets=wanted, prefix=prefix)
        if cfg.inputs == POOLED:
            from .pooled import pooled_triples, pooling

            part = pooled_triples(data, part, pooling(data), prefix)
        parts.append(part)
        targets.update({prefix + o: v for o, v in chosen.items()})
    for key, listed, found in (("holdout_velocities", cfg.holdout_velocities, held),
                               ("train_velocities", cfg.train_velocities or [], trained)):
        missed = [v for v in listed if v not in found]
        if missed:  # a holdout velocity no object recorded is held out of nothing: an evaluation would see it trained on
            raise EffectError(f"{missed[0]:g} m/s is no recorded velocity of any object of "
                              f"{', '.join(d.name for d in datasets)} (`hapticfx data info` lists them)",
                              source=cfg.source, key=key)
    first = datasets[0]
    meta = {"name": first.name if len(datasets) == 1 else f"{first.name}+{len(datasets) - 1}",
            "ref": dataset_ref(first) if len(datasets) == 1 else None, "reducer": cfg.reducer,
            "objects": list(targets), "targets": targets, "holdout": list(cfg.holdout_velocities),
            "gaps": list(cfg.gaps), "trim": cfg.trim, "inputs": cfg.inputs}
    if len(datasets) > 1:
        meta["datasets"] = [dataset_ref(d) for d in datasets]
    return datasets, concat(parts), meta


def train_from_config(cfg: TrainConfig, *, resume: bool = False, progress: bool = True) -> tuple[dict, Path]:
    """Train the configured interpolator (and write its velocity table for a one-dataset run).

    Returns the checkpoint's metadata and the weights' path.
    """
    from .tables import write_table
    from .training import train_network

    datasets, data, meta_ds = config_triples(cfg)
    out = cfg.out_dir(meta_ds["name"])
    init = None
    if cfg.init is not None:
        from . import checkpoint

        init = checkpoint.resolve(cfg.init_path())
    _, meta = train_network(cfg.interpolator, cfg.model, cfg.training, data, dataset_meta=meta_ds, out=out,
                            resume=resume, progress=progress, label=f"train {cfg.interpolator}", init=init,
                            texture=cfg.texture)
    weights = out / "model.safetensors"
    if len(datasets) == 1:  # tabulating the network takes most of a short run: told object by object
        tell = say if progress else None
        if tell:
            tell(f"velocity table: tabulating the network between recorded velocities, "
                 f"{len(datasets[0].objects)} objects")
        write_table(weights, datasets[0], progress=tell)
    return meta, weights
