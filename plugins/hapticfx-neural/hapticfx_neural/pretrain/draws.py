"""Simulated rigs for pre-training, drawn at random from ranges written down here.

Each draw is one `hapticfx data synth --spec` file: a helmet, a sensor and a few
objects, every object dropped on a dense velocity grid. The ranges are wide on
purpose (lighter and heavier objects than the built-in four, every material the
simulator knows, other helmets and sensor ranges) so that what a network learns
in pre-training is how a drop profile changes with velocity, not one rig.

Honesty: evaluation datasets are never made from these draws. The draws use their
own seed stream (``PRETRAIN_SEED`` and up, far from the seeds of the built-in set and
of the held-out specs) and their own object ids (``pre-<draw>-<k>``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from hapticfx.atomic import atomic_path

PRETRAIN_SEED = 7_000_000  # spec k is simulated with seed PRETRAIN_SEED + k

# Every range is [low, high]; "log" ranges are drawn log-uniformly.
RANGES = {
    "objects_per_rig": 3,
    "mass_kg": ("log", 0.02, 0.8),
    "side_mm": ("log", 4.0, 150.0),            # each of the three sides
    "materials": ("plastic", "concrete", "wood", "steel", "ceramic", "rubber", "aluminium", "glass"),
    "velocity_start_mps": (1.2, 4.6),          # first velocity of an object's grid
    "velocity_step_mps": 0.05,                 # the dense grid
    "velocities_per_object": 16,               # 0.75 m/s of grid
    "drops": 5,
    "helmet_mass_kg": (2.4, 4.8),
    "support_hz": (14.0, 34.0),
    "mode_hz": ((85.0, 160.0), (170.0, 320.0), (320.0, 480.0)),
    "mode_zeta": (0.015, 0.06),
    "mode_mass_kg": ("log", 1.0, 6.0),
    "mode_participation": (0.015, 0.09),       # lateral and vertical, each
    "sensor_range_g": (3.6, 6.0, 16.0),        # sensitivity 1.08 V / range (an ADXL335-like full scale)
}


def _draw(rng: np.random.Generator, spec) -> float:
    if spec[0] == "log":
        return float(math.exp(rng.uniform(math.log(spec[1]), math.log(spec[2]))))
    return float(rng.uniform(spec[0], spec[1]))


def draw_spec(k: int, *, seed: int = PRETRAIN_SEED) -> dict:
    """Spec ``k`` of the pre-training stream (a mapping ready for ``hapticfx data synth --spec``)."""
    r = RANGES
    rng = np.random.default_rng([seed, k])
    modes = [{"hz": round(_draw(rng, hz), 1), "zeta": round(_draw(rng, r["mode_zeta"]), 4),
              "mass": round(_draw(rng, r["mode_mass_kg"]), 3), "order": i + 1,
              "lateral": round(_draw(rng, r["mode_participation"]), 4),
              "vertical": round(_draw(rng, r["mode_participation"]), 4)} for i, hz in enumerate(r["mode_hz"])]
    range_g = float(rng.choice(r["sensor_range_g"]))
    objects = []
    for j in range(r["objects_per_rig"]):
        start = _draw(rng, r["velocity_start_mps"])
        grid = [round(start + i * r["velocity_step_mps"], 3) for i in range(r["velocities_per_object"])]
        objects.append({"id": f"pre-{k}-{j}", "mass_kg": round(_draw(rng, r["mass_kg"]), 4),
                        "dimensions_mm": [round(_draw(rng, r["side_mm"]), 1) for _ in range(3)],
                        "material": str(rng.choice(r["materials"])), "velocities_mps": grid})
    return {"name": f"pretrain-{k}", "seed": seed + k, "drops": r["drops"],
            "rig": {"helmet": {"mass": round(_draw(rng, r["helmet_mass_kg"]), 3),
                               "support_hz": round(_draw(rng, r["support_hz"]), 2), "modes": modes},
                    "sensor": {"range_g": range_g, "sensitivity_v_per_g": round(1.08 / range_g, 4)}},
            "objects": objects}


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
