"""The neural interpolators as hapticfx components (one class per architecture)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import ClassVar

import numpy as np

from hapticfx.errors import CheckpointError, SignalError
from hapticfx.interfaces import Interpolator, Profile
from hapticfx.signal import valid_number, valid_signal, valid_velocity

from . import checkpoint
from .samples import stack_triples

DEFAULT_GRID_STEP = 0.01


class VelocityCache:
    """Profiles precomputed on a velocity grid inside each recorded interval, blended linearly.

    Grid: for an interval ``(v_i, v_{i+1})`` the nodes are ``v_i + k * step``
    strictly inside it, plus the two ends, which hold the *recorded* profiles, so
    the cached profile is continuous at every recorded velocity.
    """

    def __init__(self, step: float):
        self.step = step
        self.intervals: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    @staticmethod
    def _key(lower: Profile, upper: Profile) -> tuple:
        # Objects of one dataset share their recorded velocities: the neighbours' samples
        # tell the objects apart.
        return (lower.velocity, upper.velocity, hash(lower.samples.tobytes()), hash(upper.samples.tobytes()))

    def add(self, bank, predict_fn) -> None:
        """Precompute the grid of every recorded interval of ``bank``."""
        rows, spans = [], []
        for i in range(len(bank) - 1):
            lo, hi = bank[i], bank[i + 1]
            inner = lo.velocity + self.step * np.arange(1, int(np.ceil((hi.velocity - lo.velocity) / self.step)))
            inner = inner[inner < hi.velocity - 1e-9]
            spans.append((lo, hi, inner, len(rows)))
            rows += [(lo, hi, float(v), None) for v in inner]
        pred = predict_fn(stack_triples(rows, [bank.object] * len(rows))) if rows else np.zeros((0, bank.n_samples))
        for lo, hi, inner, start in spans:
            nodes = np.concatenate([[lo.velocity], inner, [hi.velocity]])
            profiles = np.vstack([lo.samples[None], pred[start:start + len(inner)], hi.samples[None]])
            self.intervals[self._key(lo, hi)] = (nodes, profiles)

    @property
    def n_profiles(self) -> int:
        return sum(len(n) for n, _ in self.intervals.values())

    def lookup(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray | None:
        entry = self.intervals.get(self._key(lower, upper))
        if entry is None:
            return None
        nodes, profiles = entry
        j = int(np.clip(np.searchsorted(nodes, velocity, side="right") - 1, 0, len(nodes) - 2))
        w = (velocity - nodes[j]) / (nodes[j + 1] - nodes[j])
        return (1.0 - w) * profiles[j] + w * profiles[j + 1]


class NeuralInterpolator(Interpolator):
    """Predicts a profile from its two recorded neighbours and the velocity with a trained network.

    Options (effect ``interpolator_options``): ``weights`` (checkpoint directory or
    ``.safetensors`` file; default: the plugin's shipped weights for the effect's
    dataset and reducer), ``cache`` (precompute a velocity grid at load, default
    false), ``grid_step_mps`` (grid spacing, default 0.01), ``threads`` (torch
    threads, default 2), ``config`` (training YAML used by :meth:`fit`).
    """

    arch: ClassVar[str]

    def __init__(self, *, weights: str | os.PathLike | None = None, cache: bool = False,
                 grid_step_mps: float = DEFAULT_GRID_STEP, threads: int = 1, config: str | os.PathLike | None = None):
        if not isinstance(cache, bool):
            raise SignalError(f"interpolator_options.cache must be true or false, got {cache!r}")
        self.weights = None if weights is None else Path(weights).expanduser()
        self.use_cache = cache
        self.grid_step = valid_number(grid_step_mps, name="interpolator_options.grid_step_mps", minimum=1e-4, maximum=1.0)
        self.threads = int(valid_number(threads, name="interpolator_options.threads", minimum=1, maximum=256))
        self.config = config
        self.net = None
        self.meta: dict | None = None
        self.cache: VelocityCache | None = None

    # -- learning -------------------------------------------------------------------
    def fit(self, bank, **options) -> dict:
        """Train on one bank: every interior recorded velocity is a target (options override the config)."""
        from .config import config_from_mapping, load_config
        from .training import train_network
        from .samples import triples_from_bank

        cfg = load_config(self.config) if self.config else config_from_mapping(
            {"interpolator": self.arch, "dataset": "<bank>", "reducer": bank.reducer})
        cfg.training.update(options.pop("training", {}))
        cfg.model.update(options.pop("model", {}))
        targets = [float(v) for v in bank.velocities[1:-1]]
        data = triples_from_bank(bank, targets)
        self.net, self.meta = train_network(self.arch, cfg.model, cfg.training, data, progress=options.get("progress", False),
                                            dataset_meta={"name": options.get("dataset", "<bank>"),
                                                          "reducer": bank.reducer, "objects": [bank.object],
                                                          "targets": {bank.object: targets}})
        return {k: self.meta["training"][k] for k in ("epochs_run", "best_epoch", "train_time_s")}

    def prepare(self, bank, *, dataset=None, base_dir=None) -> None:
        """Load weights (given, or the shipped defaults for this dataset and reducer) and fill the cache.

        A relative ``weights`` path is relative to ``base_dir`` (the effect file's directory).
        """
        if self.weights is not None and base_dir is not None and not self.weights.is_absolute():
            self.weights = Path(base_dir) / self.weights
        if self.net is None:
            name = dataset.name if dataset is not None else None
            if self.weights is None:
                found = checkpoint.default_weights(name, bank.reducer, self.arch) if name else None
                if found is None:
                    raise CheckpointError(
                        f"no trained {self.arch!r} weights ship for dataset {name!r} with reducer {bank.reducer!r}; "
                        f"train them with `hapticfx train CONFIG.yaml` (interpolator: {self.arch}) and set "
                        "interpolator_options: {weights: PATH}")
                self.load(found, dataset=name, reducer=bank.reducer)
            else:
                self.load(self.weights, dataset=name, reducer=bank.reducer)
        if self.meta["n_samples"] != bank.n_samples:
            raise CheckpointError(f"{self.arch} weights expect profiles of {self.meta['n_samples']} samples; "
                                  f"bank {bank.object!r} has {bank.n_samples}")
        if self.use_cache:
            if self.cache is None:
                self.cache = VelocityCache(self.grid_step)
            self.cache.add(bank, self.predict)

    def save(self, path: Path) -> None:
        if self.net is None:
            raise CheckpointError(f"{self.arch}: nothing to save (not trained or loaded)")
        meta = {k: v for k, v in self.meta.items() if k not in ("format", "version")}
        checkpoint.save(checkpoint.resolve(path), self.net.state_dict(), meta)

    def load(self, path: Path, *, dataset: str | None = None, reducer: str | None = None) -> None:
        import torch

        from .training import load_network

        torch.set_num_threads(self.threads)
        self.net, self.meta = load_network(checkpoint.resolve(path), arch=self.arch, dataset=dataset, reducer=reducer)

    # -- inference --------------------------------------------------------------------
    def predict(self, triples) -> np.ndarray:
        from .training import predict

        if self.net is None:
            raise CheckpointError(f"{self.arch}: no weights loaded; call prepare() or load() first")
        return predict(self.net, self.meta, triples)

    def interpolate(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray:
        v = valid_velocity(velocity)
        lo = Profile(valid_velocity(lower.velocity), valid_signal(lower.samples, name="lower profile", ndim=1))
        hi = Profile(valid_velocity(upper.velocity), valid_signal(upper.samples, name="upper profile", ndim=1))
        if not lo.velocity < hi.velocity or not lo.velocity <= v <= hi.velocity:
            raise SignalError(f"velocity {v} m/s must lie between the neighbours {lo.velocity} and {hi.velocity} m/s")
        if lo.samples.shape != hi.samples.shape:
            raise SignalError(f"neighbour profiles differ in length: {lo.samples.shape} vs {hi.samples.shape}")
        if self.cache is not None:
            hit = self.cache.lookup(lo, hi, v)
            if hit is not None:
                return hit
        return self.predict(stack_triples([(lo, hi, v, None)], ["?"]))[0]


class ConvBiLSTMInterpolator(NeuralInterpolator):
    """The paper's ConvBiLSTM encoder-decoder (Sect. 4.2, Fig. 5)."""

    arch = name = "convbilstm"


class LSTMInterpolator(NeuralInterpolator):
    """Table 3 baseline: one LSTM layer (200) and a per-step dense layer."""

    arch = name = "lstm"


class BiLSTMInterpolator(NeuralInterpolator):
    """Table 3 baseline: two BiLSTM layers (200) and a per-step dense layer."""

    arch = name = "bilstm"


class LSTMSAEInterpolator(NeuralInterpolator):
    """Table 3 baseline: stacked LSTM autoencoder (trained end to end, no layer-wise pretraining)."""

    arch = name = "lstm-sae"


class BiLSTMEDInterpolator(NeuralInterpolator):
    """Table 3 baseline: BiLSTM encoder-decoder with the ConvBiLSTM's layer sizes."""

    arch = name = "bilstm-ed"


class ConvLSTMEDInterpolator(NeuralInterpolator):
    """Table 3 baseline: unidirectional ConvLSTM encoder, LSTM decoder, the ConvBiLSTM's sizes."""

    arch = name = "convlstm-ed"


CLASSES = {c.arch: c for c in (ConvBiLSTMInterpolator, LSTMInterpolator, BiLSTMInterpolator, LSTMSAEInterpolator,
                               BiLSTMEDInterpolator, ConvLSTMEDInterpolator)}
