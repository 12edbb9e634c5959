"""Simulated rigs for pre-training: the core's rig and object ranges, dense velocity grids, other seeds.

Each draw is one `hapticfx data synth --spec` file. The helmet, sensor and objects come
from :mod:`hapticfx.droprig.draws` (the ranges written down in its ``RANGES`` and in
``hapticfx/datasets/heldout/README.md``); what differs for pre-training is written here:
every object is dropped on a dense, even grid (``GRID``), so that one object gives
triples at many spacings and positions between neighbours.

Honesty: evaluation datasets are never made from these draws. Draw ``k`` uses the draw
seed and the simulation seed ``PRETRAIN_SEED + k``, outside the blocks the core reserves
for the held-out sets (:func:`hapticfx.droprig.draws.check_pretraining_seed` refuses them)
and far from the built-in set's seed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from hapticfx.atomic import atomic_path
from hapticfx.droprig.draws import RANGES, check_pretraining_seed, draw_object, draw_rig

PRETRAIN_SEED = 7_000_000

GRID = {
    "objects_per_rig": 3,
    "velocity_step_mps": 0.05,
    "velocities_per_object": 16,                                  # 0.75 m/s of grid
    "first_velocity_mps": [RANGES["v_min_mps"][0], RANGES["v_max_mps"][1] - 0.75],
    "drops": 5,
}


def draw_spec(k: int, *, seed: int = PRETRAIN_SEED) -> dict:
    """Spec ``k`` of the pre-training stream (a mapping ready for ``hapticfx data synth --spec``)."""
    s = check_pretraining_seed(seed + k)
    rng = np.random.default_rng(s)
    rig = draw_rig(rng)
    objects = []
    for j in range(GRID["objects_per_rig"]):
        o = draw_object(rng, j + 1)
        start = float(rng.uniform(*GRID["first_velocity_mps"]))
        o["velocities_mps"] = [round(start + i * GRID["velocity_step_mps"], 3)
                               for i in range(GRID["velocities_per_object"])]
        objects.append(o)
    return {"name": f"pretrain-{k}", "seed": s, "drops": GRID["drops"], "rig": rig, "objects": objects}


def write_specs(folder: Path, count: int, *, seed: int = PRETRAIN_SEED) -> list[Path]:
    """Write specs 0..count-1 as ``folder/pretrain-<k>.yaml``; returns their paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k in range(count):
        path = folder / f"pretrain-{k}.yaml"
        with atomic_path(path) as tmp:
            Path(tmp).write_text(yaml.safe_dump(draw_spec(k, seed=seed), sort_keys=False))
        paths.append(path)
    return paths
