"""Checkpoints: weights as safetensors plus a small JSON with configuration and normalisation.

A checkpoint directory holds ``model.safetensors`` + ``model.json`` (the best
weights by validation loss), ``model.table.npz`` (the network's velocity table for
every object of its dataset, see :mod:`hapticfx.interpolators.table`) and, while
training, ``resume.safetensors`` + ``resume.json`` (last weights, Adam state and RNG
state, to continue a run). The JSON records the SHA-256 of its weights; the table
records the same digest, so a table or JSON that does not belong to the weights is
refused. Nothing is pickled. Every file is written to a temporary file in the same
directory and moved into place.

Version 3: the network takes the neighbours' drop centres and outputs a correction of their
blend (:mod:`.samples`). Version 2 networks (a residual over the representatives' blend,
trained on representatives only) and version 1 networks (the profile itself) are refused.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from hapticfx.errors import CheckpointError
from hapticfx.atomic import atomic_path, user_path
from hapticfx.data.dataset import read_versioned_json

FORMAT = "hapticfx-neural-checkpoint"
VERSION = 3
WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"


def _atomic_write(path: Path, write) -> None:
    with atomic_path(path, make_parents=True) as tmp:
        write(tmp)


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _safetensors():
    """safetensors (its error class and torch module), or a one-line error that says how to install it."""
    try:
        import safetensors
        import safetensors.torch
    except ImportError:
        raise CheckpointError("reading or writing network weights needs safetensors, which is not installed: "
                              "pip install 'hapticfx-neural[train]'") from None
    return safetensors.SafetensorError, safetensors.torch


def save(path: Path, tensors: dict, meta: dict) -> None:
    """Write ``path`` (``.safetensors``) and its ``.json`` sidecar (with the weights' SHA-256) atomically."""
    SafetensorError, st = _safetensors()
    save_file = st.save_file

    path = Path(path)
    tensors = {k: v.detach().contiguous().cpu() for k, v in tensors.items()}

    def write(tmp):
        try:
            save_file(tensors, tmp)
        except SafetensorError as exc:  # its I/O errors (a full disk) are the machine's, as an OSError is
            raise OSError(str(exc).replace("Error while serializing: I/O error: ", "")) from None

    _atomic_write(path, write)
    meta = {"format": FORMAT, "version": VERSION, **meta, "weights_sha256": file_sha256(path)}
    _atomic_write(path.with_suffix(".json"), lambda tmp: Path(tmp).write_text(json.dumps(meta, indent=2) + "\n"))


def table_path(weights: Path) -> Path:
    """Where the velocity table of the weights ``weights`` (``.safetensors``) lives."""
    return Path(weights).with_suffix(".table.npz")


def resolve(ref: str | os.PathLike) -> Path:
    """``model.safetensors`` of a checkpoint given as its directory (there or to be made) or its ``.safetensors``
    file (or the ``.json`` beside it); a path to anything else is refused, named as given."""
    p = user_path(ref)
    if p.suffix in (".safetensors", ".json") and not p.is_dir():
        return p.with_suffix(".safetensors")
    if p.is_dir() or not (p.suffix or p.exists()):
        return p / "model.safetensors"
    raise CheckpointError(f"{p}: {'not a checkpoint' if p.exists() else 'checkpoint not found'}; expected a "
                          "checkpoint directory or its model.safetensors")


def read_meta(path: Path, *, arch: str | None = None) -> dict:
    """The checkpoint's validated ``.json``; with ``arch``, one of another interpolator is refused as such."""
    meta_file = Path(path).with_suffix(".json")
    if not Path(path).is_file() or not meta_file.is_file():
        raise CheckpointError(f"{path}: checkpoint not found (needs {Path(path).name} and {meta_file.name}); "
                              "train one with `hapticfx train CONFIG.yaml`")
    try:
        meta = read_versioned_json(meta_file, format=FORMAT, version=VERSION, error=CheckpointError)
    except CheckpointError as exc:
        if "format version 1;" in str(exc) or "format version 2;" in str(exc):
            raise CheckpointError(f"{exc} (older networks were trained on representatives only, not on the "
                                  "neighbours' drop centres); retrain with `hapticfx train CONFIG.yaml`") from None
        raise
    check_meta(meta, meta_file, arch=arch)
    return meta


def check_meta(meta: dict, where: Path, *, arch: str | None = None) -> None:
    """Refuse metadata that would break (or exhaust) the network built from it, naming the key; with ``arch``,
    a checkpoint of another interpolator is said to be one before its model is checked against that one's keys."""
    import math
    import re

    from .config import ADDED_MODEL_KEYS, ARCHS, MODEL_DEFAULTS, _check_model

    src = str(where)

    def need(key: str, ok: bool, expected: str) -> None:
        if not ok:
            raise CheckpointError(f"expected {expected}", source=src, key=key)

    need("interpolator", meta.get("interpolator") in ARCHS, f"one of {', '.join(ARCHS)}")
    if arch is not None:
        check_compatible(meta, where, arch=arch)
    model = meta.get("model")
    if isinstance(model, dict):  # keys added since the checkpoint was written: what it was trained with
        model = meta["model"] = {**{k: v for k, v in ADDED_MODEL_KEYS.items()
                                    if k in MODEL_DEFAULTS[meta["interpolator"]]}, **model}
    need("model", isinstance(model, dict) and set(model) == set(MODEL_DEFAULTS[meta["interpolator"]]),
         f"a mapping with {', '.join(MODEL_DEFAULTS[meta['interpolator']])}")
    _check_model(model, src, error=CheckpointError)
    n, steps = meta.get("n_samples"), meta.get("steps")
    need("n_samples", isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= 100_000, "an integer in [1, 100000]")
    need("steps", steps == model["steps"] and n % steps == 0, f"model.steps ({model['steps']}), dividing n_samples")
    norm = meta.get("normalisation")
    finite = lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)  # noqa: E731
    need("normalisation", isinstance(norm, dict) and finite(norm.get("velocity_mean"))
         and finite(norm.get("velocity_std")) and norm["velocity_std"] > 0,
         "a mapping with a finite velocity_mean and a positive velocity_std")
    ds = meta.get("dataset")
    need("dataset", isinstance(ds, dict) and isinstance(ds.get("name"), str) and isinstance(ds.get("reducer"), str),
         "a mapping with the dataset's name and reducer")
    need("weights_sha256", isinstance(meta.get("weights_sha256"), str)
         and re.fullmatch(r"[0-9a-f]{64}", meta["weights_sha256"]) is not None, "the weights' SHA-256 (64 hex digits)")
    texture = meta.get("texture")
    need("texture", texture is None or (isinstance(texture, dict) and finite(texture.get("share"))
                                        and 0 <= texture["share"] <= 1 and finite(texture.get("rate_hz"))
                                        and texture["rate_hz"] > 0),
         "a mapping with a share in [0, 1] and the banks' positive rate_hz")


def table_source(meta: dict) -> dict:
    """What a velocity table of the checkpoint ``meta`` is built from, and checked against when it is read: the
    weights, and the texture where one is kept (a table written before textures records none)."""
    source = {"weights_sha256": meta.get("weights_sha256")}
    if meta.get("texture"):
        source["texture"] = meta["texture"]["share"]
    return source


def load_tensors(path: Path, *, sha256: str | None = None) -> dict:
    """The tensors of ``path``; with ``sha256``, refused unless the file has that digest."""
    SafetensorError, st = _safetensors()
    load_file = st.load_file

    if sha256 is not None and Path(path).is_file() and file_sha256(path) != sha256:
        raise CheckpointError(f"{path}: the weights do not match {Path(path).with_suffix('.json').name} (SHA-256 "
                              "differs): the two files were not written together")
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
