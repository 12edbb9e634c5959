"""Random drop-rig specs: objects, helmets, sensors, velocity grids and drop counts drawn from written ranges.

:func:`draw_spec` turns a draw seed into a ``data synth`` spec (a plain dict, the
YAML of :mod:`hapticfx.droprig.spec`). The ranges are :data:`RANGES`; the held-out
evaluation specs (``hapticfx/datasets/heldout/*.yaml``) were drawn from them with
the seeds in :data:`HELDOUT_DRAW_SEEDS` and simulated with seeds in
:data:`HELDOUT_SIM_SEEDS`. Pre-training sets must use other draw seeds and other
simulation seeds (:func:`check_pretraining_seed` refuses the reserved block), so no
evaluation rig or object comes from the same draw as a training one.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import DatasetError
from .hertz import G

# Every range is [low, high], drawn uniformly unless marked log-uniform.
RANGES: dict = {
    "objects_per_rig": [3, 5],                     # integer
    "mass_kg": [0.02, 0.5],                        # log-uniform
    "length_mm": [30.0, 150.0],                    # longest side
    "width_frac": [0.3, 1.0],                      # x length
    "thin_plate_probability": 0.25,                # thickness 2-8 % of the length (tumbles: large spread)
    "thickness_frac": [0.2, 0.8],                  # x width, when not a plate
    "materials": ["plastic", "concrete", "wood", "steel", "ceramic", "rubber", "aluminium", "glass"],
    "velocities_per_object": [6, 12],              # integer
    "v_min_mps": [1.5, 3.0],
    "v_max_mps": [4.5, 6.5],
    "spacings": ["even", "even-height", "irregular"],  # even in v, even in drop height (v = sqrt(2 g h)), random
    "irregular_min_gap_mps": 0.12,
    "drops": [3, 12],                              # integer, per velocity
    "helmet_mass_kg": [2.0, 5.0],
    "support_hz": [15.0, 35.0],
    "rocking_hz": [6.0, 14.0],
    "dome_radius_m": [0.09, 0.13],
    "mode1_hz": [90.0, 180.0],
    "mode_ratios": [[1.9, 2.3], [3.1, 3.7]],       # second and third mode over the first
    "mode_zeta": [0.015, 0.05],
    "mode_mass_kg": [1.0, 5.0],
    "mode_participation": [0.02, 0.08],            # lateral and vertical
    # (range g, sensitivity V/g): ADXL335-, ADXL337-, ADXL326-class parts
    "sensors": [[3.6, 0.300], [3.0, 0.300], [6.0, 0.174], [16.0, 0.057]],
    "noise_ug_per_rthz": [120.0, 320.0],
    "bias_g": [-0.02, 0.02],
}

HELDOUT_DRAW_SEEDS = range(2_600_000, 2_601_000)  # reserved for evaluation rigs
HELDOUT_SIM_SEEDS = range(2_610_000, 2_611_000)   # reserved for simulating them


def check_pretraining_seed(seed: int) -> int:
    """``seed`` if it lies outside the blocks reserved for the held-out evaluation sets."""
    if seed in HELDOUT_DRAW_SEEDS or seed in HELDOUT_SIM_SEEDS:
        raise DatasetError(f"seed {seed} is reserved for the held-out evaluation sets "
                           f"({HELDOUT_DRAW_SEEDS.start}-{HELDOUT_SIM_SEEDS.stop - 1}); draw pre-training rigs "
                           "with another seed")
    return seed


def _u(rng: np.random.Generator, key: str) -> float:
    lo, hi = RANGES[key]
    return float(rng.uniform(lo, hi))


def _i(rng: np.random.Generator, key: str) -> int:
    lo, hi = RANGES[key]
    return int(rng.integers(lo, hi + 1))


def velocity_grid(rng: np.random.Generator, spacing: str, n: int, v_min: float, v_max: float) -> list[float]:
    """``n`` velocities in ``[v_min, v_max]``: even, even in drop height, or irregular (random, a minimum gap)."""
    if spacing == "even":
        v = np.linspace(v_min, v_max, n)
    elif spacing == "even-height":
        v = np.sqrt(2 * G * np.linspace(v_min**2 / (2 * G), v_max**2 / (2 * G), n))
    elif spacing == "irregular":
        gap = RANGES["irregular_min_gap_mps"]
        if (v_max - v_min) < gap * (n - 1):
            raise DatasetError(f"{n} velocities in [{v_min}, {v_max}] cannot keep a gap of {gap} m/s")
        inner = np.sort(rng.uniform(0.0, (v_max - v_min) - gap * (n - 1), n - 2))  # slack, shared out at random
        v = v_min + np.concatenate([[0.0], inner, [(v_max - v_min) - gap * (n - 1)]]) + gap * np.arange(n)
    else:
        raise DatasetError(f"unknown spacing {spacing!r}; one of {', '.join(RANGES['spacings'])}")
    return [round(float(x), 3) for x in v]


def draw_object(rng: np.random.Generator, k: int) -> dict:
    """Object number ``k``: mass, size and material (its id: ``MATERIAL-k``)."""
    length = _u(rng, "length_mm")
    width = length * _u(rng, "width_frac")
    if rng.uniform() < RANGES["thin_plate_probability"]:
        thickness = length * float(rng.uniform(0.02, 0.08))
    else:
        thickness = width * _u(rng, "thickness_frac")
    lo, hi = RANGES["mass_kg"]
    material = str(rng.choice(RANGES["materials"]))
    return {"id": f"{material}-{k}", "name": f"{material.capitalize()} object {k}", "mass_kg": round(float(math.exp(rng.uniform(math.log(lo),
            math.log(hi)))), 4), "dimensions_mm": [round(width, 1), round(length, 1), round(thickness, 1)],
            "material": material}


def draw_rig(rng: np.random.Generator) -> dict:
    """A helmet (three shell modes) and a sensor."""
    f1 = _u(rng, "mode1_hz")
    ratios = [1.0] + [float(rng.uniform(*r)) for r in RANGES["mode_ratios"]]
    modes = [{"hz": round(f1 * r, 1), "zeta": round(_u(rng, "mode_zeta"), 4), "mass": round(_u(rng, "mode_mass_kg"), 2),
              "order": k + 1, "lateral": round(_u(rng, "mode_participation"), 3),
              "vertical": round(_u(rng, "mode_participation"), 3)} for k, r in enumerate(ratios)]
    range_g, sens = RANGES["sensors"][int(rng.integers(len(RANGES["sensors"])))]
    noise = round(_u(rng, "noise_ug_per_rthz"), 1)
    return {
        "helmet": {"mass": round(_u(rng, "helmet_mass_kg"), 2), "support_hz": round(_u(rng, "support_hz"), 1),
                   "rocking_hz": round(_u(rng, "rocking_hz"), 1), "dome_radius": round(_u(rng, "dome_radius_m"), 3),
                   "modes": modes},
        "sensor": {"range_g": range_g, "sensitivity_v_per_g": sens,
                   "noise_ug_per_rthz": [noise, noise, round(2 * noise, 1)],
                   "bias_g": [round(_u(rng, "bias_g"), 4) for _ in range(3)]},
    }


def draw_spec(draw_seed: int, *, name: str, sim_seed: int, drops: int | None = None, spacing: str | None = None,
              objects: int | None = None) -> dict:
    """A whole ``data synth`` spec from ``draw_seed``; ``drops``, ``spacing`` and ``objects`` fix what is not drawn.

    Every object gets its own velocity grid (its own count, range and, unless ``spacing`` is given, spacing).
    """
    rng = np.random.default_rng(draw_seed)
    n_objects = objects or _i(rng, "objects_per_rig")
    n_drops = drops or _i(rng, "drops")
    rig = draw_rig(rng)
    objs = []
    for k in range(n_objects):
        o = draw_object(rng, k + 1)
        kind = spacing or str(rng.choice(RANGES["spacings"]))
        o["velocities_mps"] = velocity_grid(rng, kind, _i(rng, "velocities_per_object"), _u(rng, "v_min_mps"),
                                            _u(rng, "v_max_mps"))
        objs.append(o)
    return {"name": name, "seed": int(sim_seed), "drops": int(n_drops), "rig": rig, "objects": objs}
