"""Tiny network sizes and configurations for the neural plugin's tests."""

from __future__ import annotations

from pathlib import Path

TINY = {"steps": 10, "encoder_sizes": [6, 4], "decoder_sizes": [6]}
TINY_BY_ARCH = {
    "convbilstm": TINY, "convlstm-ed": TINY, "bilstm-ed": TINY,
    "lstm-sae": {"steps": 10, "encoder_sizes": [6], "decoder_sizes": [6]},
    "lstm": {"steps": 10, "sizes": [6]}, "bilstm": {"steps": 10, "sizes": [6, 6]},
}


def tiny_config(tmp: Path, dataset: Path, arch: str = "convbilstm", **training) -> Path:
    import yaml

    cfg = {"interpolator": arch, "dataset": str(dataset), "model": TINY_BY_ARCH[arch],
           "training": {"epochs": 3, "threads": 1, **training}, "out": str(tmp / f"ck-{arch}")}
    path = tmp / f"{arch}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path
