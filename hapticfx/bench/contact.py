"""Benchmarks of the contact physics (``hapticfx bench contact``).

:func:`renders` times the ``contact`` model as effects use it, over stiffness,
mass and velocity, against its budget; :func:`run` is the work-precision table
of the integration itself.

Work precision:

Each case is one drop of the drop-rig simulator (:class:`~hapticfx.droprig.contact.DropScene`,
the wood beam on the helmet) integrated over the recording window by every
solver at every tolerance. The error is measured against a float64 reference
integrated by Radau at rtol 1e-12 (its own agreement with DOP853 at 1e-12 is
reported as the reference's error bar): the largest deviation of the
object's height (micrometres) and of the helmet's accumulated impulse
(relative) on a 1 kHz grid. Function evaluations count every call of the
right-hand side, those made to build Jacobians (Radau, BDF, LSODA) included. Wall time is the median of ``repeats`` runs, with
the spread (min-max); ``ratio`` is the median time over that of the baseline
solver (RK45, explicit) at the same tolerance in the same run.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..objects import PAPER_OBJECTS
from ..droprig.contact import DropScene
from ..droprig.hertz import G
from ..droprig.state import JY, Y
from ..droprig.synth import Drop, Rig, scene_for

SOLVERS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
RTOLS = (1e-4, 1e-6, 1e-8)
BASELINE = "RK45"
REFERENCE = ("Radau", 1e-12)


@dataclass(frozen=True)
class Case:
    """One benchmark problem: a drop with a given contact stiffness."""

    name: str
    stiffness: float
    velocity: float
    damping: float | None = None
    duration_s: float = 0.55
    gap: float | None = 2e-4  # None: resting, pressed in by its own weight
    tilt: float = 0.02
    offset: float = 0.003


CASES = (
    Case("impact k=1e5", 1e5, 3.96),
    Case("impact k=1e7", 1e7, 3.96),
    Case("impact k=1e10", 1e10, 3.96),
    # the block resting flat on the crown while the helmet settles under the added weight:
    # the contact never opens, its stiff mode is barely excited
    Case("sustained k=1e5", 1e5, 0.0, gap=None, tilt=0.0, offset=0.0, duration_s=0.1),
    Case("sustained k=1e10", 1e10, 0.0, gap=None, tilt=0.0, offset=0.0, duration_s=0.1),
)


def scene(case: Case) -> DropScene:
    info = PAPER_OBJECTS["wood-beam"]
    sc = scene_for(info, Drop(case.velocity, tilt=case.tilt, offset=case.offset, stiffness=case.stiffness,
                              damping=case.damping), Rig().helmet)
    sc.gap = -((info.mass_kg * G / case.stiffness) ** (2 / 3)) if case.gap is None else case.gap
    return sc


def _run(sc: DropScene, case: Case, method: str, rtol: float):
    """Integrate once; returns the solution, wall time and right-hand side calls (Jacobians included)."""
    sc.evaluations = 0
    t0 = time.perf_counter()
    sol = sc.integrate(case.duration_s, method=method, rtol=rtol, dense=True)
    wall = time.perf_counter() - t0
    return sol, wall, sc.evaluations


def _errors(sol, ref_states: np.ndarray, grid: np.ndarray) -> tuple[float, float]:
    s = sol.sol(grid)
    pos = float(np.max(np.abs(s[Y] - ref_states[Y]))) * 1e6
    imp = float(np.max(np.abs(s[JY] - ref_states[JY])) / max(np.max(np.abs(ref_states[JY])), 1e-300))
    return pos, imp


def contact_fraction(sc: DropScene, sol, grid: np.ndarray) -> float:
    """Fraction of the grid during which the block touches the helmet."""
    states = sol.sol(grid)
    return float(np.mean([sc.closest(states[:, i])[0] > 0 for i in range(states.shape[1])]))


def run(*, cases=CASES, solvers=SOLVERS, rtols=RTOLS, repeats: int = 3,
        progress: Callable[[str], None] | None = None) -> list[dict]:
    """Measure every (case, solver, rtol); returns one row per combination."""
    say = progress or (lambda message: None)
    rows = []
    for case in cases:
        sc = scene(case)
        grid = np.linspace(0.0, case.duration_s, int(case.duration_s * 1000) + 1)
        ref, ref_wall, ref_evals = _run(sc, case, *REFERENCE)
        ref_states = ref.sol(grid)
        check = _run(sc, case, "DOP853" if case.stiffness < 1e9 else "LSODA", 1e-12)[0]
        ref_pos, ref_imp = _errors(check, ref_states, grid)
        touching = contact_fraction(sc, ref, grid)
        say(f"{case.name}: reference {REFERENCE[0]} rtol {REFERENCE[1]:g} in {ref_wall:.2f} s "
            f"({ref_evals} evaluations), in contact {touching:.0%} of the window")
        for rtol in rtols:
            base_median = None
            for method in sorted(solvers, key=lambda m: m != BASELINE):
                walls = []
                for _ in range(repeats):
                    sol, wall, evals = _run(sc, case, method, rtol)
                    walls.append(wall)
                pos, imp = _errors(sol, ref_states, grid)
                median = statistics.median(walls)
                if method == BASELINE:
                    base_median = median
                rows.append({
                    "case": case.name, "solver": method, "rtol": rtol,
                    "pos_err_um": pos, "impulse_err": imp,
                    "wall_ms": median * 1e3, "spread_ms": (min(walls) * 1e3, max(walls) * 1e3),
                    "ratio": median / base_median if base_median else float("nan"),
                    "evaluations": int(evals), "njev": int(getattr(sol, "njev", 0) or 0),
                    "ref_pos_err_um": ref_pos, "ref_impulse_err": ref_imp, "contact_fraction": touching,
                })
                say(f"  {method:6s} rtol {rtol:g}: {median * 1e3:.1f} ms, {evals} evaluations, "
                    f"height error {pos:.3g} um")
    return rows


def table(rows: list[dict]) -> str:
    """The rows as a Markdown table."""
    head = ("| case | solver | rtol | height err (um) | impulse err (rel) | wall ms (median) | spread ms "
            f"| x {BASELINE} | f evals (incl. Jacobians) | Jacobians |")
    lines = [head, "|" + "---|" * 10]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['solver']} | {r['rtol']:.0e} | {r['pos_err_um']:.3g} | {r['impulse_err']:.2g} "
            f"| {r['wall_ms']:.1f} | {r['spread_ms'][0]:.1f}-{r['spread_ms'][1]:.1f} | {r['ratio']:.2f} "
            f"| {r['evaluations']} | {r['njev']} |"
        )
    refs = {}
    for r in rows:
        refs.setdefault(r["case"], (r["ref_pos_err_um"], r["ref_impulse_err"], r["contact_fraction"]))
    lines.append("")
    lines.append(f"Reference: {REFERENCE[0]} rtol {REFERENCE[1]:g} (float64); its distance to an independent "
                 "tight solution (DOP853 rtol 1e-12, LSODA for k=1e10):")
    for name, (pos, imp, frac) in refs.items():
        lines.append(f"- {name}: {pos:.2g} um height, {imp:.2g} impulse; block in contact {frac:.0%} of the window")
    return "\n".join(lines)



RENDER_STIFFNESS = (1e3, 1e6, 1e8, 1e10)
RENDER_MASSES = (1e-6, 1e-3, 0.1, 1.0, 10.0)
RENDER_VELOCITIES = (1e-6, 0.01, 0.5, 5.0, 50.0)
RENDER_BUDGET_MS = 50.0


def renders(*, stiffness=RENDER_STIFFNESS, masses=RENDER_MASSES, velocities=RENDER_VELOCITIES,
            repeats: int = 3, progress: Callable[[str], None] | None = None) -> list[dict]:
    """Time ``ContactModel`` renders (500 ms at 1 kHz, the defaults) over the grid; one row per stiffness.

    Each render is of a velocity the model has not cached. Beside it, in the same
    run, the integration alone two ways on the model's own grid and at its tolerance:
    ``DropScene.sample`` (what the model uses) and scipy's ``solve_ivp`` dense solution
    evaluated on the grid (the baseline), with the largest difference of the helmet's acceleration they
    give, relative to its peak (velocities from 0.01 m/s).
    """
    from ..interfaces import Impact
    from ..models.contact import RTOL, ContactModel
    from ..objects import ObjectInfo
    from ..params import BuildContext

    say = progress or (lambda message: None)
    rows = []
    for k in stiffness:
        walls, sample_walls, dense_walls, diffs, peaks = [], [], [], [], []
        for mass in masses:
            info = ObjectInfo("block", "block", mass, (60.0, 60.0, 30.0), "wood")
            # every render integrates (no velocity table), up to the fastest impact the model takes
            model = ContactModel(ContactModel.Params(stiffness=k, table=False, max_velocity_mps=100.0),
                                 BuildContext(object_info=info))
            for i, v in enumerate(velocities):
                for r in range(repeats):
                    fresh = v * (1.0 + 1e-9 * (r + 1))  # a velocity the model has not rendered
                    t0 = time.perf_counter()
                    out = model.render(Impact("block", fresh))
                    walls.append(time.perf_counter() - t0)
                peaks.append(out.peak)
                scene, rate, n_fine, lead = model.scene(info, v)
                t0 = time.perf_counter()
                fast = scene.sample(n_fine - lead, rate, rtol=RTOL)
                sample_walls.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                dense = scene.integrate((n_fine - lead - 1) / rate, rtol=RTOL).sol(np.arange(n_fine - lead) / rate)
                dense_walls.append(time.perf_counter() - t0)
                if v >= 0.01:  # below, the response is under 1e-6 g and the tolerances are absolute
                    a = scene.helmet.sensor_acceleration(fast, rate)
                    b = scene.helmet.sensor_acceleration(dense, rate)
                    diffs.append(float(np.max(np.abs(a - b)) / np.max(np.abs(b))))
            say(f"k={k:.0e} mass {mass:g} kg: slowest render so far {max(walls) * 1e3:.1f} ms")
        w = np.array(walls) * 1e3
        rows.append({
            "stiffness": k, "renders": int(w.size), "median_ms": float(np.median(w)),
            "p99_ms": float(np.percentile(w, 99)), "max_ms": float(w.max()),
            "sample_ms": float(np.median(sample_walls) * 1e3), "dense_ms": float(np.median(dense_walls) * 1e3),
            "max_state_diff": max(diffs), "peak_g": (min(peaks), max(peaks)),
        })
    return rows


def render_table(rows: list[dict]) -> str:
    """The render rows as a Markdown table."""
    lines = ["| k (N/m^1.5) | renders | median ms | p99 ms | max ms | within budget | integration ms: "
             "sample (odeint) | solve_ivp dense (baseline) | x baseline | largest acceleration difference | peak g (min-max) |",
             "|" + "---|" * 11]
    for r in rows:
        ok = "yes" if r["max_ms"] <= RENDER_BUDGET_MS else "NO"
        lines.append(
            f"| {r['stiffness']:.0e} | {r['renders']} | {r['median_ms']:.1f} | {r['p99_ms']:.1f} | {r['max_ms']:.1f} "
            f"| {ok} | {r['sample_ms']:.1f} | {r['dense_ms']:.1f} | {r['sample_ms'] / r['dense_ms']:.2f} "
            f"| {r['max_state_diff']:.1e} | {r['peak_g'][0]:.2g}-{r['peak_g'][1]:.3g} |"
        )
    return "\n".join(lines)
