"""Training loop: RMSE loss against drop means, Adam, early stopping on a validation split, checkpoints, resume.

Every epoch draws the neighbours' input centres afresh from random subsets of their drops
(:meth:`~.samples.DropTriples.centres`), from a generator seeded by (seed, epoch) so that a
resumed run draws what an uninterrupted one would. The validation split holds out whole
target velocities (every triple of a held-out (object, velocity) pool), scored with the
full centres as inputs. Fine-tuning (``init``) starts from another checkpoint's weights and
keeps its velocity normalisation.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import time
from pathlib import Path

import numpy as np
import torch

from hapticfx.atomic import check_writable
from hapticfx.errors import CheckpointError, DatasetError
from hapticfx.progress import Progress

from . import checkpoint
from .networks import blend_plus_correction, build_network
from .samples import DropTriples, Triples, decode, encode, table_residual
from .texture import chosen_texture


def make_network(arch: str, model: dict, n_samples: int) -> torch.nn.Module:
    steps = int(model["steps"])
    if n_samples % steps:
        raise DatasetError(f"profiles of {n_samples} samples cannot be cut into model.steps={steps} equal steps")
    return build_network(arch, model, width=n_samples // steps, steps=steps)


def n_parameters(net: torch.nn.Module) -> int:
    return int(sum(p.numel() for p in net.parameters()))


def _rmse(pred, y):
    return torch.sqrt(torch.mean((pred - y) ** 2) + 1e-12)


def _split(data: DropTriples, fraction: float, gen: torch.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Train and validation triples; the validation split holds out whole target pools."""
    pools = np.unique(data.tgt)
    n = len(pools)
    n_val = 0 if fraction <= 0 or n < 5 else max(1, int(round(fraction * n)))
    held = pools[torch.randperm(n, generator=gen).numpy()[:n_val]]
    val = np.isin(data.tgt, held)
    return np.flatnonzero(~val), np.flatnonzero(val)


def _optimizer_tensors(opt: torch.optim.Adam) -> tuple[dict, dict]:
    sd = opt.state_dict()
    tensors = {}
    for idx, st in sd["state"].items():
        for k, v in st.items():
            tensors[f"opt.{idx}.{k}"] = v if torch.is_tensor(v) else torch.tensor(v)
    return tensors, {"param_groups": sd["param_groups"]}


def _load_optimizer(opt: torch.optim.Adam, tensors: dict, groups: list) -> None:
    state: dict = {}
    for key, v in tensors.items():
        if key.startswith("opt."):
            _, idx, name = key.split(".", 2)
            state.setdefault(int(idx), {})[name] = v
    opt.load_state_dict({"state": state, "param_groups": groups})


def train_network(arch: str, model: dict, training: dict, data: DropTriples, *, dataset_meta: dict,
                  out: Path | None = None, resume: bool = False, progress: bool = True,
                  label: str | None = None, init: Path | None = None,
                  texture: float | str = 0.0) -> tuple[torch.nn.Module, dict]:
    """Train interpolator ``arch`` on ``data``; returns the best network (by validation RMSE) and its metadata.

    With ``out``, writes ``model.safetensors/.json`` (best) and ``resume.*`` (last
    epoch) there; ``resume=True`` continues from ``out/resume.*``. ``init``: a checkpoint
    to fine-tune (same interpolator and sizes). ``texture``: the share of the neighbours' fine detail its
    profiles keep, or ``"choose"`` it on the validation targets once trained (:mod:`.texture`).
    """
    if len(data) == 0:
        raise DatasetError("no training triples: a target needs a recorded velocity on each side")
    if out is not None:
        try:  # found now, not after the first epoch
            check_writable(out)
        except OSError as exc:
            raise CheckpointError(f"{out}: cannot write the checkpoint there ({exc.strerror or exc}); "
                                  "nothing was trained") from None
    data = dataclasses.replace(data, input_drops=training.get("input_drops"))
    torch.set_num_threads(int(training["threads"]))
    device = _device(training.get("device", "cpu"))
    seed = int(training["seed"])
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    n_samples = data.n_samples
    net = make_network(arch, model, n_samples)
    tr_idx, va_idx = _split(data, training["val_fraction"], gen)
    v_mean = float(np.mean(data.v[tr_idx]))
    v_std = float(np.std(data.v[tr_idx])) or 1.0
    started_from = None
    if init is not None:
        net, init_meta = load_network(init, arch=arch, n_samples=n_samples)
        if init_meta["model"] != model:
            raise CheckpointError(f"{init}: cannot fine-tune: its model sizes {init_meta['model']} differ from {model}")
        v_mean, v_std = init_meta["normalisation"]["velocity_mean"], init_meta["normalisation"]["velocity_std"]
        started_from = {"weights": str(init), "weights_sha256": init_meta["weights_sha256"],
                        "dataset": init_meta["dataset"].get("name")}
    net.to(device)
    opt = torch.optim.Adam(net.parameters(), lr=training["learning_rate"], betas=(training["beta1"], 0.999))

    def enc(t: Triples):
        x, vel, y = encode(t, steps=model["steps"], v_mean=v_mean, v_std=v_std)
        return tuple(torch.from_numpy(a).to(device) for a in (x, vel, y))

    def loss_of(x, vel, y):
        return _rmse(blend_plus_correction(x, vel, net(x, vel)), y)

    train_set = data.subset(tr_idx)
    xv, vv, yv = enc(data.subset(va_idx).centres()) if len(va_idx) else (None, None, None)
    meta = {
        "interpolator": arch, "model": copy.deepcopy(model), "n_samples": int(n_samples), "steps": int(model["steps"]),
        "output": "correction of the blend of the neighbours' drop centres (hapticfx_neural.samples)",
        "normalisation": {"profile": "divided by max(|lower centre|, |upper centre|) per impact",
                          "velocity_features": ["(v - v_lower) / (v_upper - v_lower)", "(v - velocity_mean) / velocity_std"],
                          "velocity_mean": v_mean, "velocity_std": v_std},
        "dataset": dataset_meta, "parameters": n_parameters(net), "init": started_from,
        "training": {**copy.deepcopy(training), "n_train": int(len(tr_idx)), "n_val": int(len(va_idx))},
    }
    net.eval()
    with torch.no_grad():
        start_val = float(loss_of(xv, vv, yv)) if xv is not None else None
    # Epoch 0 (the untrained network: the blend of the neighbours' centres) is a candidate like any other:
    # training keeps a change only where validation improves on where it started.
    state = {"epoch": 0, "best": math.inf if start_val is None else start_val, "best_epoch": 0, "bad": 0,
             "elapsed_s": 0.0, "history": [], "start_val": start_val}
    best_state = copy.deepcopy(net.state_dict())
    if resume:
        state, best_state = _resume(out, net, opt, gen, meta)
    bar = None
    if progress:
        bar = Progress(training["epochs"], label or arch, unit="epochs", done=state["epoch"]).__enter__()
    created = out is not None and not Path(out).exists()
    bs = int(training["batch_size"])
    t0 = time.perf_counter() - state["elapsed_s"]
    while state["epoch"] < training["epochs"] and state["bad"] < training["patience"]:
        net.train()
        draw = np.random.default_rng([seed, state["epoch"]]) if training["augment"] else None
        xt, vt, yt = enc(train_set.centres(draw))
        perm = torch.randperm(len(tr_idx), generator=gen)
        total = 0.0
        for start in range(0, len(perm), bs):
            b = perm[start:start + bs]
            opt.zero_grad()
            loss = loss_of(xt[b], vt[b], yt[b])
            loss.backward()
            opt.step()
            total += loss.item() ** 2 * len(b)
        train_rmse = math.sqrt(total / len(perm))
        net.eval()
        with torch.no_grad():
            val_rmse = float(loss_of(xv, vv, yv)) if xv is not None else train_rmse
        state["epoch"] += 1
        state["history"].append([train_rmse, val_rmse])
        if val_rmse < state["best"] - 1e-7:
            state.update(best=val_rmse, best_epoch=state["epoch"], bad=0)
            best_state = copy.deepcopy(net.state_dict())
            if out is not None:
                _saved(lambda: _save_best(out, best_state, meta, state, t0), out, created)
        else:
            state["bad"] += 1
        state["elapsed_s"] = time.perf_counter() - t0
        if out is not None:
            _saved(lambda: _save_resume(out, net, opt, gen, meta, state), out, created)
        if bar is not None:
            bar.update(note=f"loss {train_rmse:.4f}, val {val_rmse:.4f}, best epoch {state['best_epoch']}")
    if bar is not None:
        bar.close()
    net.to("cpu")  # served, tabulated and saved from the CPU
    net.load_state_dict(best_state)
    net.eval()
    meta["training"].update(_summary(state, t0), stopped_early=state["bad"] >= training["patience"])
    kept = chosen_texture(texture, lambda t: predict_correction(net, meta, t), data.subset(va_idx))
    if kept is not None:
        meta["texture"] = kept
    if out is not None:
        _saved(lambda: _save_best(out, best_state, meta, state, t0), out, created)
    return net, meta


def _saved(save, out: Path, created: bool) -> None:
    """Run ``save``; a full disk or unwritable directory is one error that says what was kept."""
    try:
        save()
    except OSError as exc:
        if created and Path(out).is_dir() and not any(Path(out).iterdir()):
            Path(out).rmdir()  # this run made it and nothing in it survived
            kept = "nothing was saved"
        else:
            kept = _resumable(out)
        raise CheckpointError(f"{out}: cannot write the checkpoint ({exc.strerror or exc}); {kept}") from None


def _resumable(out: Path) -> str:
    """What a run that stopped can continue from in ``out``: the epoch its resume state holds, if it holds one."""
    try:
        epoch = checkpoint.read_meta(Path(out) / "resume.safetensors")["resume"]["epoch"]
    except (CheckpointError, KeyError, TypeError):
        return "no resume state is saved there"
    return f"epoch {epoch} is saved there: continue with --resume once it can be written"


def _summary(state: dict, t0: float) -> dict:
    return {"epochs_run": state["epoch"], "best_epoch": state["best_epoch"], "best_val_rmse_normalised": state["best"],
            "start_val_rmse_normalised": state["start_val"], "train_time_s": time.perf_counter() - t0,
            "history": state["history"]}


def _save_best(out: Path, best_state: dict, meta: dict, state: dict, t0: float) -> None:
    m = copy.deepcopy(meta)
    m["training"].update(_summary(state, t0))
    checkpoint.save(Path(out) / "model.safetensors", best_state, m)


def _save_resume(out: Path, net, opt, gen, meta: dict, state: dict) -> None:
    tensors = {f"net.{k}": v for k, v in net.state_dict().items()}
    opt_t, opt_meta = _optimizer_tensors(opt)
    tensors.update(opt_t)
    tensors["rng.torch"] = torch.get_rng_state()
    tensors["rng.shuffle"] = gen.get_state()
    checkpoint.save(Path(out) / "resume.safetensors", tensors, {**meta, "resume": {**state, **opt_meta}})


def _resume(out: Path | None, net, opt, gen, meta: dict) -> tuple[dict, dict]:
    if out is None:
        raise CheckpointError("resume needs an output directory")
    path = Path(out) / "resume.safetensors"
    old = checkpoint.read_meta(path)
    for key in ("interpolator", "model", "n_samples", "dataset", "normalisation"):
        if old.get(key) != json.loads(json.dumps(meta[key])):
            raise CheckpointError(f"{path}: cannot resume: its {key} differs from this configuration "
                                  f"({old.get(key)!r} vs {meta[key]!r}); start afresh without --resume")
    changed = [k for k in meta["training"] if k not in ("epochs", "patience", "device")
               and old["training"].get(k) != meta["training"][k]]
    if changed:
        raise CheckpointError(f"{path}: cannot resume: training.{changed[0]} differs from the checkpoint")
    tensors = checkpoint.load_tensors(path, sha256=old["weights_sha256"])
    net.load_state_dict({k[4:]: v for k, v in tensors.items() if k.startswith("net.")})
    _load_optimizer(opt, tensors, old["resume"]["param_groups"])
    torch.set_rng_state(tensors["rng.torch"])
    gen.set_state(tensors["rng.shuffle"])
    state = {k: old["resume"][k] for k in ("epoch", "best", "best_epoch", "bad", "elapsed_s", "history", "start_val")}
    best_path = Path(out) / "model.safetensors"
    best = checkpoint.load_tensors(best_path) if best_path.is_file() else copy.deepcopy(net.state_dict())
    return state, best


def _device(name: str) -> torch.device:
    """The torch device ``training.device`` names, refused in one line where this torch or machine has none."""
    if name.startswith("cuda") and not torch.cuda.is_available():
        why = "this torch is a CPU build" if torch.version.cuda is None else "no CUDA GPU is visible"
        raise CheckpointError(f"training.device {name!r}: {why}; train with device: cpu")
    if name.startswith("cuda:") and int(name[5:]) >= torch.cuda.device_count():
        raise CheckpointError(f"training.device {name!r}: this machine has {torch.cuda.device_count()} CUDA GPU(s)")
    return torch.device(name)


def load_network(path: Path, *, arch: str, n_samples: int | None = None, dataset: str | None = None,
                 reducer: str | None = None) -> tuple[torch.nn.Module, dict]:
    """A trained network from a checkpoint, refused clearly if it was built for something else."""
    meta = checkpoint.read_meta(path, arch=arch)
    checkpoint.check_compatible(meta, path, arch=arch, n_samples=n_samples, dataset=dataset, reducer=reducer)
    net = make_network(arch, meta["model"], int(meta["n_samples"]))
    tensors = checkpoint.load_tensors(path, sha256=meta["weights_sha256"])
    try:
        net.load_state_dict(tensors)
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()
        raise CheckpointError(f"{path}: weights do not fit the {arch} network described in its .json "
                              f"({first[1].strip() if len(first) > 1 else first[0]})") from exc
    net.eval()
    return net, meta


def predict_correction(net: torch.nn.Module, meta: dict, data: Triples, *, batch: int = 64) -> np.ndarray:
    """The network's correction ``(n, N)`` for ``data``, computed in the network's own precision."""
    norm = meta["normalisation"]
    x, vel, _ = encode(data, steps=int(meta["steps"]), v_mean=norm["velocity_mean"], v_std=norm["velocity_std"])
    dtype = next(net.parameters()).dtype
    outs = []
    with torch.inference_mode():
        for s in range(0, len(x), batch):
            xb = torch.from_numpy(x[s:s + batch]).to(dtype)
            vb = torch.from_numpy(vel[s:s + batch]).to(dtype)
            outs.append(net(xb, vb).double().numpy())
    return np.concatenate(outs).reshape(len(data), -1)


def predict(net: torch.nn.Module, meta: dict, data: Triples, *, batch: int = 64) -> np.ndarray:
    """Profiles ``(n, N)`` (float64, bank units) predicted for ``data``."""
    return decode(data, predict_correction(net, meta, data, batch=batch), meta.get("texture"))


def predict_residual(net: torch.nn.Module, meta: dict, data: Triples, *, batch: int = 64) -> np.ndarray:
    """The core's table residual ``(n, N)`` of the prediction for ``data``."""
    return table_residual(data, predict_correction(net, meta, data, batch=batch), meta.get("texture"))
