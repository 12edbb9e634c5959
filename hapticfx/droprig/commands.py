"""The ``hapticfx data synth`` and ``data draw``, ``hapticfx bench contact``, ``bench synth``, ``bench physics`` and
``bench families`` commands."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Optional

import typer

from ..errors import DatasetError, SignalError
from ..progress import say
from . import MAX_SEED


def _floats(text: str, *, option: str) -> list[float]:
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise SignalError(f"{option} must be comma-separated numbers, got {text!r}") from None
    if not values:
        raise SignalError(f"{option} is empty")
    return values




def synth(
    out: Optional[Path] = typer.Argument(None, help="Dataset directory to write (not with --builtin)."),
    builtin: bool = typer.Option(False, "--builtin", help="Regenerate the packaged builtin:helmet-drops dataset."),
    objects: str = typer.Option("all", "--objects", metavar="ID,...",
                                help="Comma-separated built-in object ids, or 'all'."),
    velocities: Optional[str] = typer.Option(None, "--velocities", metavar="M/S,...",
                                             help="Comma-separated velocities in m/s, 2 or more "
                                             "(default: the paper's 12)."),
    drops: Optional[int] = typer.Option(None, "--drops", metavar="COUNT", min=1, max=1000,
                                        help="Drops per velocity (default: 10, or the --spec's count, which this "
                                             "replaces: the same rig and objects recorded more or fewer times)."),
    seed: int = typer.Option(20230417, "--seed", metavar="SEED", min=0, max=MAX_SEED,
                             help="Random seed: the same seed gives the same recordings."),
    workers: int = typer.Option(0, "--jobs", "-j", "--workers", metavar="COUNT", min=0, max=256,
                                help="Processes simulating drops in parallel (joblib, loky); 0: every core. "
                                     "Any value gives the same recordings."),
    force: bool = typer.Option(False, "--force", help="Replace OUT if it exists."),
    heldout: Optional[str] = typer.Option(None, "--heldout", metavar="NAME",
                                          help="Simulate a held-out evaluation set by name "
                                          "(or 'all') into the cache `heldout:NAME` reads (or into OUT); see "
                                          "hapticfx/datasets/heldout/README.md."),
    spec: Optional[Path] = typer.Option(None, "--spec", metavar="YAML",
                                        help="YAML spec: other objects (mass, size, material), "
                                        "velocities per object, drops, seed, helmet and sensor (see docs/physics.md), "
                                        "or an impact family's effect file with its velocities (docs/families.md); "
                                        "not with --objects, --velocities, --seed."),
):
    """Simulate drops on the helmet rig and write a dataset (raw 3-axis recordings + banks).

    The simulator: Hunt-Crossley contact with rebounds, helmet modes, an
    ADXL335-like sensor behind a 14-bit DAQ at 1 kHz. See docs/physics.md.
    """
    from ..objects import PAPER_OBJECTS, builtin_object
    from . import synth as sim
    from .spec import SPEC_VELOCITIES

    started = time.perf_counter()
    if heldout is not None:
        from ..evaluation import heldout as held

        if builtin or spec is not None or objects != "all" or velocities is not None or drops is not None \
                or seed != sim.BUILTIN_SEED:
            raise DatasetError("--heldout simulates a fixed spec; it takes no --builtin, --spec, --objects, "
                               "--velocities, --drops or --seed")
        names = list(held.HELDOUT) if heldout == "all" else [heldout]
        if out is not None and len(names) > 1:
            raise DatasetError("give one --heldout NAME with OUT (or no OUT for 'all': they go to the cache)")
        for name in names:
            held.spec_path(name)  # an unknown name fails before any simulation
        for name in names:
            typer.echo(f"{name}: {held.ensure(name, workers=workers, out=out, progress=say)}")
        typer.echo(f"done in {time.perf_counter() - started:.1f} s")
        return
    if builtin:
        if out is not None or objects != "all" or velocities is not None or drops is not None \
                or seed != sim.BUILTIN_SEED:
            raise DatasetError("--builtin regenerates the packaged dataset exactly; it takes no OUT, --objects, "
                               "--velocities, --drops or --seed")
        path = sim.synth_builtin(workers=workers, progress=say)
    elif spec is not None:
        from .spec import load_spec

        if out is None:
            raise DatasetError("give an output directory for --spec")
        if objects != "all" or velocities is not None or seed != sim.BUILTIN_SEED:
            raise DatasetError("--spec gives the objects, velocities and seed; drop --objects, --velocities and "
                               "--seed")
        s = load_spec(spec)
        path = sim.synth_dataset(out, s.objects, s.velocities, drops=drops or s.drops, seed=s.seed, name=s.name,
                                 rig=s.rig, variation=s.variation, workers=workers, overwrite=force, progress=say,
                                 command=f"hapticfx data synth {out} --spec {spec}"
                                 + (f" --drops {drops}" if drops else ""))
    else:
        if out is None:
            raise DatasetError("give an output directory (or --builtin)")
        infos = list(PAPER_OBJECTS.values()) if objects == "all" else [
            builtin_object(o.strip(), key="--objects") for o in objects.split(",") if o.strip()]
        vs = list(sim.PAPER_VELOCITIES) if velocities is None else _floats(velocities, option="--velocities")
        far = [v for v in vs if not SPEC_VELOCITIES[0] <= v <= SPEC_VELOCITIES[1]]
        if far:  # said before anything is simulated, as typed (a drop's velocity varies around it)
            raise DatasetError(f"--velocities: {far[0]:g} m/s is outside {SPEC_VELOCITIES[0]:g}-"
                               f"{SPEC_VELOCITIES[1]:g} m/s, the drop rig's range (as in a spec file)")
        drops = drops or sim.BUILTIN_DROPS
        command = (f"hapticfx data synth {out} --objects {','.join(i.id for i in infos)} "
                   f"--velocities {','.join(f'{v:g}' for v in vs)} --drops {drops} --seed {seed}")
        path = sim.synth_dataset(out, infos, vs, drops=drops, seed=seed, workers=workers,
                                 overwrite=force, progress=say, command=command)
    typer.echo(f"wrote {path} in {time.perf_counter() - started:.1f} s")


SIM_SEED_OFFSET = 10_000  # a drawn rig is simulated with its draw seed + this


def draw(
    seeds: list[int] = typer.Argument(..., metavar="SEED...", min=0, max=MAX_SEED - SIM_SEED_OFFSET,
                                      help="Draw seeds, one rig each."),
    out: Path = typer.Option(..., "--out", "-o", metavar="DIR", help="Folder for the specs (draw-SEED.yaml)."),
    drops: Optional[int] = typer.Option(None, "--drops", metavar="COUNT", min=1, max=1000,
                                        help="Drops per velocity (default: drawn, 3-12)."),
    spacing: Optional[str] = typer.Option(None, "--spacing", metavar="even|even-height|irregular",
                                          help="Velocity spacing of every object (default: drawn per object)."),
    force: bool = typer.Option(False, "--force", help="Replace a spec file that is not this draw (one edited, or "
                               "drawn with other options)."),
):
    """Draw rigs (helmet, sensor, 3-5 objects, their velocities and drop counts) from the ranges the held-out
    sets were drawn from, as `data synth --spec` files.

    Each rig is simulated with seed SEED + 10000. Seeds reserved for the held-out evaluation sets are refused
    (hapticfx/datasets/heldout/README.md): a method tuned on drawn rigs is still proved on those sets.
    Then: `hapticfx data synth DIR/rig --spec DIR/draw-SEED.yaml`.
    """
    import yaml

    from ..atomic import atomic_path, existing_folder
    from .draws import RANGES, check_pretraining_seed, draw_spec

    if spacing is not None and spacing not in RANGES["spacings"]:
        raise DatasetError(f"--spacing must be one of {', '.join(RANGES['spacings'])}, got {spacing!r}")
    existing_folder(out)
    specs, texts = {}, {}
    for seed in seeds:  # every seed and file checked before anything is written
        check_pretraining_seed(seed)
        check_pretraining_seed(seed + SIM_SEED_OFFSET)
        specs[seed] = draw_spec(seed, name=f"draw-{seed}", sim_seed=seed + SIM_SEED_OFFSET, drops=drops,
                                spacing=spacing)
        path = out / f"draw-{seed}.yaml"
        header = (f"# Drawn by `hapticfx data draw {seed}` from hapticfx.droprig.draws.RANGES"
                  f"{'' if drops is None else f' --drops {drops}'}{'' if spacing is None else f' --spacing {spacing}'}.\n")
        texts[seed] = header + yaml.safe_dump(specs[seed], sort_keys=False)
        if path.exists() and not force and not (path.is_file() and path.read_text(errors="replace") == texts[seed]):
            raise DatasetError(f"{path}: exists and is not this draw (edited, or drawn with other options); "
                               "use --force to replace it")
    for seed, spec in specs.items():
        path = out / f"draw-{seed}.yaml"
        with atomic_path(path, make_parents=True) as tmp:
            tmp.write_text(texts[seed])
        objects = ", ".join(f"{o['material']} {o['mass_kg']:g} kg ({len(o['velocities_mps'])} v)"
                            for o in spec["objects"])
        typer.echo(f"{path}: {spec['drops']} drops; {objects}")


def bench_contact(
    repeats: int = typer.Option(3, "--repeats", metavar="COUNT", min=1, max=100,
                                help="Timed runs per solver and tolerance."),
    solvers: str = typer.Option("RK45,DOP853,Radau,BDF,LSODA", "--solvers", metavar="NAME,...",
                                help="scipy solve_ivp methods for the work-precision table; 'none' skips it."),
    rtols: str = typer.Option("1e-4,1e-6,1e-8", "--rtols", metavar="TOL,...", help="Relative tolerances."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="FILE", help="Also write the rows as JSON here."),
):
    """Contact physics: the contact model's render time over stiffness, mass and velocity against its
    50 ms budget, then a work-precision table of the integration (soft k=1e5 to very stiff k=1e10)."""
    from ..bench import contact as contact_bench

    names = [] if solvers.strip() == "none" else [s.strip() for s in solvers.split(",") if s.strip()]
    known = {"RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"}
    bad = [n for n in names if n not in known]
    if bad:
        raise SignalError(f"--solvers: unknown solver {bad[0]!r}; known: {', '.join(sorted(known))}, or none")
    tols = _floats(rtols, option="--rtols")
    if any(not 1e-13 <= t <= 1e-1 for t in tols):
        raise SignalError(f"--rtols must lie in [1e-13, 0.1], got {tols}")
    render_rows = contact_bench.renders(repeats=repeats, progress=say)
    typer.echo(f"## contact model renders (budget {contact_bench.RENDER_BUDGET_MS:g} ms each)\n")
    typer.echo(contact_bench.render_table(render_rows))
    rows = contact_bench.run(solvers=names, rtols=tols, repeats=repeats, progress=say) if names else []
    if rows:
        typer.echo("\n## work precision of the integration\n")
        typer.echo(contact_bench.table(rows))
    if out is not None:
        from ..atomic import atomic_path

        with atomic_path(out) as tmp:
            tmp.write_text(json.dumps({"renders": render_rows, "solvers": rows}, indent=2) + "\n")
        typer.echo(f"wrote {out}")


def bench_synth(
    jobs: str = typer.Option("2", "--jobs", "-j", metavar="COUNT,...",
                             help="Comma-separated process counts to compare with serial (1)."),
    drops: int = typer.Option(5, "--drops", metavar="COUNT", min=1, max=100, help="Drops per velocity."),
    velocities: int = typer.Option(12, "--velocities", metavar="COUNT", min=1, max=12,
                                   help="How many of the paper's velocities."),
    repeats: int = typer.Option(3, "--repeats", metavar="COUNT", min=1, max=50, help="Timed runs per process count."),
):
    """Parallel simulation: `data synth`'s drops (wood beam, same seed) serially and through joblib with
    --jobs processes; median wall time [min, max], speed-up over serial, and whether the arrays match."""
    from ..bench import synth as synth_bench

    counts = [int(x) for x in _floats(jobs, option="--jobs")]
    if any(n < 1 or n > 256 for n in counts):
        raise SignalError(f"--jobs must be process counts in [1, 256], got {jobs!r}")
    rows = synth_bench.run(jobs=counts, drops=drops, velocities=velocities, repeats=repeats, progress=say)
    typer.echo(synth_bench.table(rows))


def bench_physics(
    effects: Optional[list[Path]] = typer.Argument(None, help="Effect files on the contact model (default: every "
                                                   "shipped family in effects/families/)."),
    velocities: int = typer.Option(10000, "--velocities", metavar="COUNT", min=1,
                                   help="Random velocities per effect, uniform over "
                                   "the table's knots (each one integrated directly)."),
    seed: int = typer.Option(0, "--seed", metavar="SEED", help="Seed of the random velocities."),
):
    """Velocity tables of the physics models: the largest difference from direct integration at random velocities
    (relative to the peak at each), the time each took to build and its size; direct integration and table
    lookups timed per impact (the lookup before shaping)."""
    from ..bench import physics

    typer.echo(physics.run(effects, velocities=velocities, seed=seed))


def bench_families(
    plot: Optional[Path] = typer.Option(None, "--plot", metavar="PNG",
                                        help="Also write the four families' spectra (PNG) here."),
):
    """Each impact family against the published quantities it must match: quantity, source, range, rendered
    value (docs/families.md)."""
    from ..bench import families

    typer.echo(families.run(plot))


def register(bench: typer.Typer, data: typer.Typer) -> None:
    bench.command("physics")(bench_physics)
    bench.command("families")(bench_families)
    data.command("synth")(synth)
    data.command("draw")(draw)
    bench.command("synth")(bench_synth)
    bench.command("contact")(bench_contact)
