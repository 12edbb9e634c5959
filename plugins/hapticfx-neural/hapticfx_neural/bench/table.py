"""`hapticfx bench table`: a trained network's velocity table against the network itself.

Draws velocities uniformly over every object's recorded range and compares the
table's profile with direct inference (both float64) relative to the profile's
peak; measures the jump at every interior recorded velocity (r +- 1e-9 m/s)
through the data-driven model in both modes; and times a lookup against an
inference at batch 1, and loading the table against loading the network.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from hapticfx.timing import measure, ms, table


def bench_table(
    weights: Optional[Path] = typer.Option(None, "--weights", metavar="DIR",
                                           help="Checkpoint directory (default: the shipped "
                                           "ConvBiLSTM for builtin:helmet-drops)."),
    dataset: str = typer.Option("builtin:helmet-drops", "--dataset", "-d", metavar="DATASET",
                                help="The dataset the table covers."),
    velocities: int = typer.Option(10_000, "--velocities", metavar="COUNT", min=10, help="Random velocities compared."),
    repeats: int = typer.Option(50, "--repeats", metavar="COUNT", min=5, help="Timed lookups and inferences."),
    seed: int = typer.Option(0, "--seed", metavar="SEED", help="Seed of the random velocities."),
):
    """Velocity table against direct inference: largest difference, jumps at recorded velocities, run time."""
    from hapticfx.data.dataset import open_dataset
    from hapticfx.interpolators.table import VelocityTable
    from hapticfx.models.datadriven import DataDrivenModel
    from hapticfx.params import BuildContext
    from hapticfx.registry import get_registry

    from .. import checkpoint
    from ..interpolator import require_torch

    require_torch("`hapticfx bench table`")
    ds = open_dataset(dataset)
    meta_path = checkpoint.resolve(weights) if weights else checkpoint.default_weights(ds.name, "max-min", "convbilstm")
    meta = checkpoint.read_meta(meta_path)
    arch, reducer = meta["interpolator"], meta["dataset"]["reducer"]
    options = {"weights": str(meta_path)}
    tabled = get_registry().create("interpolator", arch, **options)
    direct = get_registry().create("interpolator", arch, **options, cache=False)
    banks = {o: ds.bank(o, reducer) for o in ds.objects}
    for bank in banks.values():
        tabled.prepare(bank, dataset=ds)
        direct.prepare(bank, dataset=ds)
    rng = np.random.default_rng(seed)
    objs = rng.choice(list(banks), size=velocities)
    worst, started = 0.0, time.perf_counter()
    for obj in banks:
        bank = banks[obj]
        vs = rng.uniform(bank.velocities[0], bank.velocities[-1], int(np.sum(objs == obj)))
        vs = vs[[bank.index_of(float(v)) is None for v in vs]]
        rows = [(*bank.neighbours(float(v)), float(v), None) for v in vs]
        want = direct.predict(direct.triples(rows, [obj] * len(rows)))
        for (lo, hi, v, _), d in zip(rows, want):
            worst = max(worst, float(np.max(np.abs(tabled.interpolate(lo, hi, v) - d)) / np.max(np.abs(d))))
        typer.echo(f"{obj}: {len(rows)} velocities compared", err=True)
    compare_s = time.perf_counter() - started
    jumps = {}
    for mode, cache in (("table", True), ("direct", False)):
        params = DataDrivenModel.Params(dataset=dataset, reducer=reducer, interpolator=arch,
                                        interpolator_options={**options, "cache": cache})
        model = DataDrivenModel(params, BuildContext())
        worst_jump = 0.0
        for obj, bank in banks.items():
            for k, r in enumerate(bank.velocities[1:-1], start=1):
                ref = bank.profiles[k]
                for side in (-1e-9, 1e-9):
                    jump = np.max(np.abs(model.profile(obj, float(r) + side) - ref)) / np.max(np.abs(ref))
                    worst_jump = max(worst_jump, float(jump))
        jumps[mode] = worst_jump
    obj = next(iter(banks))
    lo, hi = banks[obj].neighbours(float(np.mean(banks[obj].velocities[:2])))
    v = 0.5 * (lo.velocity + hi.velocity)
    t_table = measure(lambda: tabled.interpolate(lo, hi, v), repeat=max(repeats, 200))
    t_direct = measure(lambda: direct.interpolate(lo, hi, v), repeat=repeats)
    t0 = time.perf_counter()
    VelocityTable.load(checkpoint.table_path(meta_path))
    load_table = time.perf_counter() - t0
    t0 = time.perf_counter()
    get_registry().create("interpolator", arch, **options, cache=False).load(meta_path)
    load_net = time.perf_counter() - t0
    typer.echo(f"{arch} weights {meta_path}; {velocities} random velocities over {len(banks)} objects, seed {seed} "
               f"(compared in {compare_s:.0f} s)")
    typer.echo(table(["what", "value"], [
        ["largest abs(table - direct) / peak, random velocities", f"{worst:.2e}"],
        ["largest jump / peak at r +- 1e-9 m/s, table", f"{jumps['table']:.2e}"],
        ["largest jump / peak at r +- 1e-9 m/s, direct", f"{jumps['direct']:.2e}"],
        ["table lookup, median / p99 (ms)", f"{ms(t_table.median)} / {ms(t_table.p99)}"],
        ["direct inference (float64), median / p99 (ms)", f"{ms(t_direct.median)} / {ms(t_direct.p99)}"],
        ["direct / table, median", f"{t_direct.median / t_table.median:,.0f}"],
        ["load the table (ms)", ms(load_table)],
        ["load the network (ms, torch already imported)", ms(load_net)],
    ]))
