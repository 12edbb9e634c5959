"""The neural interpolators as hapticfx components (one class per architecture).

At play time a trained network is served from its velocity table (numbers next to
the weights, :mod:`hapticfx.interpolators.table`): no torch import. torch runs only
to train, to build a table, or when an effect asks for direct inference
(``cache: false``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import ClassVar

import numpy as np

from hapticfx.atomic import user_path
from hapticfx.errors import CheckpointError, SignalError
from hapticfx.interfaces import Profile, TrainingData
from hapticfx.interpolators.table import TableServed, VelocityTable, neighbours
from hapticfx.signal import valid_number

from . import checkpoint
from .config import POOLED
from .samples import Centres, Triples, stack_triples


def require_torch(why: str) -> None:
    """Import torch or say, in one line, how to install it."""
    try:
        import torch  # noqa: F401
    except ImportError:
        raise CheckpointError(f"{why} needs torch, which is not installed: "
                              "pip install 'hapticfx-neural[train]'") from None


class NeuralInterpolator(TableServed):
    """Predicts a profile from its two recorded neighbours and the velocity with a trained network.

    The network takes the neighbours' drop centres (the mean, or trimmed mean, of every drop
    recorded at each) and predicts the centre at the velocity; the profile is the neighbours' blend drawn toward
    it (:mod:`.samples`). Where a neighbour's drops are unknown its representative stands in.

    Options (effect ``interpolator_options``): ``weights`` (checkpoint directory or
    ``.safetensors`` file; default: the plugin's shipped weights for the effect's
    dataset and reducer), ``cache`` (default true: serve the velocity table written
    next to the weights; false: run the network for every impact, which needs
    torch), ``threads`` (torch threads for direct inference, default 1: on a shared
    2-core machine two threads spin-wait for each other), ``config`` (training YAML
    used by :meth:`fit`).
    """

    arch: ClassVar[str]

    def __init__(self, *, weights: str | os.PathLike | None = None, cache: bool = True, threads: int = 1,
                 config: str | os.PathLike | None = None):
        if not isinstance(cache, bool):
            raise SignalError(f"interpolator_options.cache must be true or false, got {cache!r}")
        self.weights = None if weights is None else user_path(weights)
        self.use_table = cache
        self.threads = int(valid_number(threads, name="interpolator_options.threads", minimum=1, maximum=256))
        self.config = config
        self.net = None
        self.meta: dict | None = None
        self.table: VelocityTable | None = None
        self.centres = Centres()

    # -- learning -------------------------------------------------------------------
    def fit(self, data: TrainingData, **options) -> dict:
        """Train on every object of ``data`` (one network, as in the paper); options override the config.

        Targets: ``data.targets`` when given, else every interior recorded velocity of each bank.
        """
        require_torch(f"training {self.arch}")
        from .config import config_from_mapping, load_config
        from .run import triples_of
        from .training import train_network

        cfg = load_config(self.config) if self.config else config_from_mapping(
            {"interpolator": self.arch, "dataset": data.dataset, "reducer": data.reducer})
        cfg.training.update(options.get("training") or {})
        cfg.model.update(options.get("model") or {})
        triples, targets = triples_of(data, gaps=cfg.gaps, trim=cfg.trim)
        if cfg.inputs == POOLED:
            from .pooled import pooled_centres, pooled_triples, pooling

            fit = pooling(data)
            triples, centres = pooled_triples(data, triples, fit), pooled_centres(data, fit, cfg.trim)
        else:
            centres = Centres(cfg.trim)
            for obj, bank in data.banks.items():
                centres.add(bank, data.drops.get(obj))
        init = options.get("init", cfg.init_path())
        self.net, self.meta = train_network(
            self.arch, cfg.model, cfg.training, triples, progress=options.get("progress", False),
            label=options.get("label"), init=None if init is None else checkpoint.resolve(init), texture=cfg.texture,
            dataset_meta={"name": data.dataset, "reducer": data.reducer, "objects": list(data.banks),
                          "targets": targets, "gaps": list(cfg.gaps), "trim": cfg.trim, "inputs": cfg.inputs})
        self.net = self.net.double()  # served in float64, like its table
        self.table = None
        self.centres = centres
        return {**{k: self.meta["training"][k] for k in ("epochs_run", "best_epoch", "train_time_s")},
                "texture": (self.meta.get("texture") or {}).get("share", 0.0)}

    def tabulate(self, data: TrainingData) -> VelocityTable:
        """A velocity table of the network trained by :meth:`fit` over the banks of ``data``."""
        from .tables import network_table

        if self.net is None:
            raise CheckpointError(f"{self.arch}: nothing to tabulate (not trained or loaded)")
        return network_table(self.net, self.meta, list(data.banks.values()), data.dataset, self.centres)

    # -- loading ----------------------------------------------------------------------
    def prepare(self, bank, *, dataset=None, base_dir=None) -> None:
        """Serve ``bank`` from the weights' velocity table (or load the network for ``cache: false``).

        A relative ``weights`` path is relative to ``base_dir`` (the effect file's directory).
        """
        if self.weights is None and self.net is not None:
            return  # trained by fit() in this process and not saved: served by direct inference
        name = dataset.name if dataset is not None else None
        path = self._weights_path(bank, name, base_dir)
        if not self.use_table:
            if self.net is None:
                self.load(path, dataset=name, reducer=bank.reducer)
            checkpoint.check_compatible(self.meta, path, arch=self.arch, n_samples=bank.n_samples)
            if dataset is not None:
                from .tables import dataset_centres

                self.centres = dataset_centres(self.meta, dataset, [bank.object], bank.reducer)
            return
        if self.table is None:
            meta = checkpoint.read_meta(path, arch=self.arch)
            checkpoint.check_compatible(meta, path, arch=self.arch, n_samples=bank.n_samples, dataset=name,
                                        reducer=bank.reducer)
            table = VelocityTable.load(checkpoint.table_path(path), rebuild=_rebuild_hint(path))
            table.check_source(self.arch, checkpoint.table_source(meta), rebuild=_rebuild_hint(path))
            self.table, self.meta = table, meta
        self.table.attach(bank, rebuild=_rebuild_hint(path))

    def _weights_path(self, bank, dataset_name: str | None, base_dir) -> Path:
        if self.weights is not None:
            if base_dir is not None and not self.weights.is_absolute():
                self.weights = Path(base_dir) / self.weights
            return checkpoint.resolve(self.weights)
        found = checkpoint.default_weights(dataset_name, bank.reducer, self.arch) if dataset_name else None
        if found is None:
            raise CheckpointError(
                f"no trained {self.arch!r} weights ship for dataset {dataset_name!r} with reducer {bank.reducer!r}; "
                f"train them with `hapticfx train CONFIG.yaml` (interpolator: {self.arch}) and set "
                "interpolator_options: {weights: PATH}")
        self.weights = found
        return found

    def save(self, path: Path) -> None:
        if self.net is None:
            raise CheckpointError(f"{self.arch}: nothing to save (not trained or loaded)")
        meta = {k: v for k, v in self.meta.items() if k not in ("format", "version", "weights_sha256")}
        checkpoint.save(checkpoint.resolve(path), self.net.state_dict(), meta)

    def load(self, path: Path, *, dataset: str | None = None, reducer: str | None = None) -> None:
        """Load the network itself (torch) for direct inference, in float64 like its table."""
        require_torch(f"direct {self.arch} inference (interpolator_options.cache: false)")
        import torch

        from .training import load_network

        torch.set_num_threads(self.threads)
        net, self.meta = load_network(checkpoint.resolve(path), arch=self.arch, dataset=dataset, reducer=reducer)
        self.net = net.double()
        self.centres = Centres.of(self.meta)

    # -- inference --------------------------------------------------------------------
    def predict(self, triples) -> np.ndarray:
        from .training import predict

        if self.net is None:
            if self.weights is None:
                raise CheckpointError(f"{self.arch}: no weights loaded; call prepare() or load() first")
            self.load(self.weights)
        return predict(self.net, self.meta, triples)

    def triples(self, rows, objects) -> "Triples":
        """Inference triples for ``(lower, upper, velocity, None)`` rows, with the neighbours' drop centres."""
        return stack_triples(rows, objects, self.centres)

    def interpolate(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray:
        lo, hi, v = neighbours(lower, upper, velocity)
        if self.table is not None:
            hit = self.table.lookup(lo, hi, v)
            if hit is not None:
                return hit
        return self.predict(self.triples([(lo, hi, v, None)], ["?"]))[0]

    def describe(self) -> dict:
        if self.table is not None:
            return {"served_from": self.table.describe()}
        return {"served_from": f"direct inference ({self.weights})"}


def _rebuild_hint(weights: Path) -> str:
    return f"rebuild it with `hapticfx table {weights.parent}`"


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
