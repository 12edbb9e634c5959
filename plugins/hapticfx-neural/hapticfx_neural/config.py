"""Training configuration: the YAML schema, the paper's sizes as defaults, validation.

No torch here: the CLI reads and checks a configuration before importing it.
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from hapticfx.errors import EffectError

ARCHS = ("convbilstm", "lstm", "bilstm", "lstm-sae", "bilstm-ed", "convlstm-ed")

# Paper Sect. 4.2 / 5.1. Table 3 gives sizes only for `lstm` (200) and `bilstm`
# (2 x 200); the encoder-decoder baselines use the ConvBiLSTM's layer sizes, and
# the stacked LSTM autoencoder a symmetric 128-64 / 64-128 stack.
_ED = {"encoder_sizes": [256, 128, 64], "decoder_sizes": [256, 180, 150],
       "encoder_dropout": 0.4, "decoder_dropout": 0.3, "decoder_input": "repeat"}
MODEL_DEFAULTS: dict[str, dict] = {
    "convbilstm": {"steps": 50, "kernel": 3, **_ED},
    "convlstm-ed": {"steps": 50, "kernel": 3, **_ED},
    "bilstm-ed": {"steps": 50, **_ED},
    "lstm-sae": {"steps": 50, "encoder_sizes": [128, 64], "decoder_sizes": [64, 128],
                 "encoder_dropout": 0.2, "decoder_dropout": 0.2, "decoder_input": "repeat"},
    "lstm": {"steps": 50, "sizes": [200], "dropout": 0.0},
    "bilstm": {"steps": 50, "sizes": [200, 200], "dropout": 0.0},
}
# What an encoder-decoder's decoder reads at each step: "repeat", the paper's repeat vector (the encoder's final
# state, the same at every step); "sequence", the encoder's output at that step (docs/neural.md: through the
# repeat vector the decoder could not place a correction in time, and the network learned nothing even where a
# linear learner could).
DECODER_INPUTS = ("repeat", "sequence")
# Model keys added after checkpoints were first written, and what a checkpoint without them was trained with.
ADDED_MODEL_KEYS = {"decoder_input": "repeat"}
TRAINING_DEFAULTS = {
    "epochs": 100, "batch_size": 8, "learning_rate": 1e-4, "beta1": 0.9, "val_fraction": 0.2,
    "patience": 30, "seed": 0, "threads": 1, "augment": True, "input_drops": None, "device": "cpu",
}
TOP_KEYS = ("interpolator", "dataset", "reducer", "objects", "train_velocities", "holdout_velocities",
            "gaps", "trim", "texture", "inputs", "init", "model", "training", "out")
# What the network reads of each neighbour: its drop centre, or the centres ensemble-warp pools across velocity
# (:mod:`.pooled`).
POOLED = "pooled"
INPUTS = ("centres", POOLED)
# How much of the recorded neighbours' fine detail a trained network's profiles keep (the core's
# hapticfx.interpolators.texture): a share in [0, 1], or CHOOSE to pick it on the validation targets after training.
CHOOSE = "choose"
MAX_GAP = 16


@dataclass
class TrainConfig:
    """One training run: which interpolator, on which data, with which sizes and schedule."""

    interpolator: str
    dataset: str | list[str]
    reducer: str = "max-min"
    objects: list[str] | None = None
    train_velocities: list[float] | None = None
    holdout_velocities: list[float] = field(default_factory=list)
    gaps: list[int] = field(default_factory=lambda: [1])
    trim: float = 0.0
    texture: float | str = 0.0
    inputs: str = "centres"
    init: str | None = None
    model: dict = field(default_factory=dict)
    training: dict = field(default_factory=dict)
    out: str | None = None
    source: str = "<config>"

    def __post_init__(self):
        if self.interpolator not in ARCHS:
            raise EffectError(f"unknown neural interpolator {self.interpolator!r}; one of: {', '.join(ARCHS)}",
                              source=self.source, key="interpolator")
        self.model = _merge(MODEL_DEFAULTS[self.interpolator], self.model, self.source, "model")
        self.training = _merge(TRAINING_DEFAULTS, self.training, self.source, "training")
        _check_model(self.model, self.source)
        _check_training(self.training, self.source)
        for key in ("train_velocities", "holdout_velocities"):
            vals = getattr(self, key)
            if vals is not None:
                if not isinstance(vals, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                         and v >= 0 for v in vals):
                    raise EffectError("expected a list of non-negative velocities in m/s", source=self.source, key=key)
                setattr(self, key, [float(v) for v in vals])
        if not (isinstance(self.gaps, list) and self.gaps and all(
                isinstance(g, int) and not isinstance(g, bool) and 1 <= g <= MAX_GAP for g in self.gaps)):
            raise EffectError(f"expected a non-empty list of integers in [1, {MAX_GAP}] (recorded velocities between "
                              "a target and each neighbour)", source=self.source, key="gaps")
        if isinstance(self.trim, bool) or not (isinstance(self.trim, (int, float)) and 0 <= self.trim < 0.5):
            raise EffectError("expected a number in [0, 0.5): the fraction of drops cut at each end, per sample, "
                              "for a velocity's centre (0: the mean)", source=self.source, key="trim")
        self.trim = float(self.trim)
        if self.texture != CHOOSE:
            if isinstance(self.texture, bool) or not (isinstance(self.texture, (int, float)) and 0 <= self.texture <= 1):
                raise EffectError(f"expected a number in [0, 1] (the share of the neighbours' detail above 100 Hz the "
                                  f"profiles keep) or {CHOOSE} (chosen on the validation targets)", source=self.source,
                                  key="texture")
            self.texture = float(self.texture)
        if self.inputs not in INPUTS:
            raise EffectError(f"expected one of {', '.join(INPUTS)} (what the network reads of each neighbour)",
                              source=self.source, key="inputs")
        if self.inputs == POOLED and self.training["input_drops"] is not None:
            raise EffectError("expected null with inputs: pooled (pooled inputs are pooled from every drop; "
                              "input_drops draws raw centres)", source=self.source, key="training.input_drops")
        if self.init is not None and not isinstance(self.init, str):
            raise EffectError("expected a checkpoint path (string)", source=self.source, key="init")
        if self.objects is not None and not (isinstance(self.objects, list) and all(isinstance(o, str) for o in self.objects)):
            raise EffectError("expected a list of object ids", source=self.source, key="objects")

    @property
    def datasets(self) -> list[str]:
        return [self.dataset] if isinstance(self.dataset, str) else list(self.dataset)

    def out_dir(self, dataset_name: str) -> Path:
        """``out``, or ``checkpoints/<interpolator>-<dataset>-<reducer>`` under the current directory.

        Never the plugin's shipped weights unless asked for (`hapticfx train --ship`)."""
        return Path(self.out) if self.out else Path("checkpoints") / f"{self.interpolator}-{dataset_name}-{self.reducer}"

    def init_path(self) -> Path | None:
        """``init``, relative to the configuration file's folder (the current folder for a mapping), as
        ``dataset`` is: the same file fine-tunes the same weights from `hapticfx train` and from a bench row."""
        if self.init is None:
            return None
        return (Path(self.source).parent if self.source != "<config>" else Path()) / self.init

    def as_dict(self) -> dict:
        return {k: copy.deepcopy(getattr(self, k)) for k in TOP_KEYS}


def _merge(defaults: dict, given, source: str, key: str) -> dict:
    if given is None:
        given = {}
    if not isinstance(given, dict):
        raise EffectError("expected a mapping", source=source, key=key)
    unknown = sorted(set(given) - set(defaults))
    if unknown:
        raise EffectError(f"unknown key(s) {', '.join(unknown)}; allowed: {', '.join(defaults)}",
                          source=source, key=key)
    merged = copy.deepcopy(defaults)
    merged.update(given)
    return merged


MAX_LAYER = 2048  # units or filters per layer: the paper's largest is 256
MAX_LAYERS = 8


def _check_model(m: dict, source: str, error: type = EffectError) -> None:
    for k, v in m.items():
        where = f"model.{k}"
        if k.endswith("_sizes") or k == "sizes":
            if not (isinstance(v, list) and 0 < len(v) <= MAX_LAYERS and all(
                    isinstance(x, int) and not isinstance(x, bool) and 0 < x <= MAX_LAYER for x in v)):
                raise error(f"expected a list of 1 to {MAX_LAYERS} integers in [1, {MAX_LAYER}]", source=source, key=where)
        elif k.endswith("dropout"):
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and 0 <= v < 1):
                raise error("expected a number in [0, 1)", source=source, key=where)
        elif k == "decoder_input":
            if v not in DECODER_INPUTS:
                raise error("expected repeat (the paper's repeat vector) or sequence (the encoder's output at each "
                            "step)", source=source, key=where)
        elif k in ("steps", "kernel"):
            if not (isinstance(v, int) and not isinstance(v, bool) and 0 < v <= 100_000) or (k == "kernel" and v % 2 == 0):
                raise error("expected a positive integer (kernel: odd)", source=source, key=where)
        else:
            raise error(f"unknown key {k!r}", source=source, key="model")


def _check_training(t: dict, source: str) -> None:
    ints = {"epochs": 1, "batch_size": 1, "patience": 1, "seed": 0, "threads": 1}
    for k, lo in ints.items():
        v = t[k]
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= lo):
            raise EffectError(f"expected an integer >= {lo}", source=source, key=f"training.{k}")
    k = t["input_drops"]
    count = lambda x: isinstance(x, int) and not isinstance(x, bool) and x >= 1  # noqa: E731
    if not (k is None or count(k) or (isinstance(k, list) and len(k) == 2 and all(map(count, k)) and k[0] <= k[1])):
        raise EffectError("expected an integer >= 1 (the most drops a neighbour's input centre is drawn from), a "
                          "range [fewest, most] of such integers, or null (every drop)", source=source,
                          key="training.input_drops")
    if not (isinstance(t["device"], str) and re.fullmatch(r"cpu|cuda(:\d+)?", t["device"])):
        raise EffectError("expected cpu, cuda or cuda:N (where torch trains; CUDA needs a CUDA build of torch and "
                          "a GPU)", source=source, key="training.device")
    if not isinstance(t["augment"], bool):
        raise EffectError("expected true or false", source=source, key="training.augment")
    for k, lo, hi in (("learning_rate", 0, 1), ("beta1", 0, 1), ("val_fraction", 0, 0.9)):
        v = t[k]
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and lo <= v <= hi and (k == "val_fraction" or v > 0)):
            raise EffectError(f"expected a number in [{lo}, {hi}]", source=source, key=f"training.{k}")


def load_config(path: str | Path) -> TrainConfig:
    """Read a training configuration YAML (safe loader; unknown keys are errors)."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise EffectError(f"cannot read: {exc.strerror}", source=str(path)) from exc
    except yaml.YAMLError as exc:
        raise EffectError(f"not valid YAML: {exc}", source=str(path)) from exc
    return config_from_mapping(data, source=str(path))


def config_from_mapping(data, *, source: str = "<config>") -> TrainConfig:
    if not isinstance(data, dict):
        raise EffectError("expected a mapping at the top level", source=source)
    unknown = sorted(set(data) - set(TOP_KEYS))
    if unknown:
        raise EffectError(f"unknown key(s) {', '.join(unknown)}; allowed: {', '.join(TOP_KEYS)}", source=source)
    if not isinstance(data.get("interpolator"), str):
        raise EffectError("required (a string)", source=source, key="interpolator")
    ds = data.get("dataset")
    if not (isinstance(ds, str) or (isinstance(ds, list) and ds and all(isinstance(d, str) for d in ds))):
        raise EffectError("required: a dataset (path or builtin:NAME) or a non-empty list of them", source=source,
                          key="dataset")
    return TrainConfig(**data, source=source)
