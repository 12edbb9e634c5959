"""Checkpoints: weights as safetensors plus a small JSON with configuration and normalisation.

A checkpoint directory holds ``model.safetensors`` + ``model.json`` (the best
weights by validation loss) and, while training, ``resume.safetensors`` +
``resume.json`` (last weights, Adam state and RNG state, to continue a run).
Nothing is pickled. Every file is written to a temporary file in the same
directory and moved into place.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from hapticfx.errors import CheckpointError
from hapticfx.atomic import atomic_path
from hapticfx.data.dataset import read_versioned_json

FORMAT = "hapticfx-neural-checkpoint"
VERSION = 1
WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"


def _atomic_write(path: Path, write) -> None:
    with atomic_path(path, make_parents=True) as tmp:
        write(tmp)


def save(path: Path, tensors: dict, meta: dict) -> None:
    """Write ``path`` (``.safetensors``) and its ``.json`` sidecar atomically."""
    from safetensors.torch import save_file

    path = Path(path)
    tensors = {k: v.detach().contiguous().cpu() for k, v in tensors.items()}
    _atomic_write(path, lambda tmp: save_file(tensors, tmp))
    _atomic_write(path.with_suffix(".json"),
                  lambda tmp: Path(tmp).write_text(json.dumps({"format": FORMAT, "version": VERSION, **meta}, indent=2) + "\n"))


def resolve(ref: str | os.PathLike) -> Path:
    """``model.safetensors`` of a checkpoint given as its directory or its file."""
    p = Path(ref).expanduser()
    if p.is_dir():
        p = p / "model.safetensors"
    if p.suffix != ".safetensors":
        p = p.with_suffix(".safetensors")
    return p


def read_meta(path: Path) -> dict:
    meta_file = Path(path).with_suffix(".json")
    if not Path(path).is_file() or not meta_file.is_file():
        raise CheckpointError(f"{path}: checkpoint not found (needs {Path(path).name} and {meta_file.name}); "
                              "train one with `hapticfx train CONFIG.yaml`")
    return read_versioned_json(meta_file, format=FORMAT, version=VERSION, error=CheckpointError)


def load_tensors(path: Path) -> dict:
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    try:
        return load_file(str(path))
    except (SafetensorError, OSError, ValueError) as exc:
        raise CheckpointError(f"{path}: corrupt or unreadable weights ({exc})") from exc


def check_compatible(meta: dict, path: Path, *, arch: str, n_samples: int | None = None,
                     dataset: str | None = None, reducer: str | None = None) -> None:
    """Refuse a checkpoint built for another architecture, profile length or dataset."""
    where = f"{path}: "
    if meta.get("interpolator") != arch:
        raise CheckpointError(where + f"built for interpolator {meta.get('interpolator')!r}, not {arch!r}")
    if n_samples is not None and meta.get("n_samples") != n_samples:
        raise CheckpointError(where + f"built for profiles of {meta.get('n_samples')} samples; this bank has {n_samples}")
    ds = meta.get("dataset", {})
    if dataset is not None and ds.get("name") != dataset:
        raise CheckpointError(where + f"trained on dataset {ds.get('name')!r}, not {dataset!r}; "
                              "train one for this dataset with `hapticfx train CONFIG.yaml`")
    if reducer is not None and ds.get("reducer") != reducer:
        raise CheckpointError(where + f"trained on reducer {ds.get('reducer')!r} profiles, not {reducer!r}")


def default_weights(dataset: str, reducer: str, arch: str) -> Path | None:
    """The shipped weights for (dataset name, reducer, interpolator), or None."""
    p = WEIGHTS_DIR / dataset / reducer / arch / "model.safetensors"
    return p if p.is_file() and p.with_suffix(".json").is_file() else None
