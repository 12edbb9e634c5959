"""The ``hapticfx data ...`` commands and ``hapticfx bench reducers``."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from ..cli.show import JSON_HELP
from ..errors import DatasetError, HapticfxError
from ..progress import say

DEFAULT_DATASET = "builtin:helmet-drops"
DATASET_HELP = "Dataset path, builtin:NAME or heldout:NAME (a held-out set made by `data synth --heldout NAME`)."
FEW_DROPS = 5  # drops a velocity under which a velocity's mean is mostly sampling noise (docs/data.md)


def few_drops(meta: dict) -> str | None:
    """A one-line note naming the objects of a dataset's ``meta`` with fewer than :data:`FEW_DROPS` drops a
    velocity, or None."""
    few = [f"{obj} ({o['n_drops']})" for obj, o in meta["objects"].items()
           if isinstance(o.get("n_drops"), int) and o["n_drops"] < FEW_DROPS]
    if not few:
        return None
    return (f"fewer than {FEW_DROPS} drops a velocity: {', '.join(few)}; the data-driven models interpolate from each "
            "velocity's mean of drops, and with so few its error is mostly sampling noise: record "
            f"{FEW_DROPS} or more, 10 as the paper does (docs/data.md, \"How many drops\")")


def _open(ref: str):
    """The dataset ``ref`` names; ``heldout:NAME`` is a held-out set's simulated copy, or says how to make it."""
    from ..evaluation import heldout
    from .dataset import open_dataset

    if ref.startswith(heldout.PREFIX):
        name = ref[len(heldout.PREFIX):]
        path = heldout.dataset_path(name)  # an unknown name is refused with the known ones
        if not (path / "dataset.json").is_file():
            raise DatasetError(f"{ref}: not simulated on this machine yet; make it with `hapticfx data synth "
                               f"--heldout {name}` (about a minute)")
        ref = str(path)
    return open_dataset(ref)


def _pairs(items: list[str], option: str) -> dict[str, str]:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise DatasetError(f"{option} {item!r}: expected KEY=VALUE")
        out[key.strip()] = value.strip()
    return out




def import_(
    files: List[Path] = typer.Argument(..., help="Tidy CSV file(s): object,velocity_mps,drop,t_s,ax_g,ay_g,az_g."),
    out: Path = typer.Option(..., "--out", "-o", metavar="DIR", help="Dataset directory to create."),
    name: Optional[str] = typer.Option(None, metavar="NAME", help="Dataset name (default: the directory name)."),
    sensor: List[str] = typer.Option([], metavar="KEY=VALUE",
                                     help="Sensor metadata KEY=VALUE, repeatable (e.g. model=ADXL335)."),
    mass: List[str] = typer.Option([], metavar="OBJECT=KG",
                                   help="OBJECT=KG for objects that are not built in, repeatable."),
    force: bool = typer.Option(False, "--force", help="Replace an existing dataset at --out."),
):
    """Import drop recordings from tidy CSV into a dataset (raw + max-min and dft321 banks).

    Every bad row is reported with its line number; nothing is written unless all is good.
    """
    from .csv_import import import_csv
    from .dataset import open_dataset

    masses = {}
    for k, v in _pairs(mass, "--mass").items():
        try:
            masses[k] = float(v)
        except ValueError:
            raise DatasetError(f"--mass {k}={v}: the mass must be a number in kg") from None
    path = import_csv(files, out, name=name, sensor=_pairs(sensor, "--sensor") or None, masses=masses,
                      overwrite=force, progress=say)
    note = few_drops(open_dataset(path).meta)
    if note:
        say(f"note: {note}")
    typer.echo(str(path))


def record(
    port: str = typer.Option(..., "--port", "-p", metavar="PORT",
                             help="Serial port of the accelerometer board, e.g. /dev/ttyACM0."),
    object: str = typer.Option(..., "--object", metavar="OBJECT", help="Object id written into each file."),
    height_m: float = typer.Option(..., "--height-m", metavar="METRES", help="Drop height in metres; v = sqrt(2 g h)."),
    drops: int = typer.Option(10, metavar="COUNT", help="Number of drops to record."),
    out_dir: Path = typer.Option(Path("recordings"), "--out-dir", metavar="DIR",
                                 help="Folder for the per-drop CSV files."),
    threshold_g: float = typer.Option(0.5, metavar="G",
                                      help="Trigger: deviation from rest of the acceleration vector, in g."),
    pre_trigger: int = typer.Option(50, metavar="SAMPLES", help="Samples kept from before the trigger."),
    samples: int = typer.Option(1000, metavar="SAMPLES", help="Samples per drop (pre-trigger included)."),
    timeout_s: float = typer.Option(60.0, metavar="SECONDS",
                                    help="Give up when no impact comes within this many seconds."),
    baud: int = typer.Option(500000, metavar="BAUD", help="Serial baud rate (the sketch uses 500000)."),
):
    """Record triggered drops from the serial accelerometer board, one CSV file per drop."""
    from ..board.record import record_drops

    files = record_drops(port, object_id=object, height_m=height_m, drops=drops, out_dir=out_dir,
                         threshold_g=threshold_g, pre_trigger=pre_trigger, n_samples=samples,
                         timeout_s=timeout_s, baud=baud, progress=say)
    for f in files:
        typer.echo(str(f))


def plot(
    object: str = typer.Argument(..., help="Object id."),
    dataset: str = typer.Option(DEFAULT_DATASET, metavar="DATASET", help=DATASET_HELP),
    reducer: str = typer.Option("max-min", metavar="NAME", help="Reducer whose bank and drops are drawn."),
    velocity: Optional[float] = typer.Option(None, metavar="M/S",
                                             help="Velocity (m/s) whose drops are drawn (default: middle one)."),
    out: Path = typer.Option(Path("profiles.png"), "--out", "-o", metavar="PNG", help="PNG file to write."),
    force: bool = typer.Option(False, "--force", help="Replace an output file that hapticfx did not write "
                               "(a plot it wrote is replaced anyway)."),
):
    """Plot the drops at one velocity with the chosen representative, and the profiles across velocities."""
    from ..actuators.files import check_overwrite
    from .plot import plot_object

    if out.suffix.lower() != ".png":  # it writes PNG data whatever the name says
        raise HapticfxError(f"{out}: the plot is a PNG image; give --out a .png file")
    check_overwrite(out, force=force)
    typer.echo(str(plot_object(_open(dataset), object, out, reducer=reducer, velocity=velocity)))


def info(
    dataset: str = typer.Argument(DEFAULT_DATASET, help=DATASET_HELP),
    as_json: bool = typer.Option(False, "--json", help=JSON_HELP),
):
    """Describe a dataset: what made it, rates, sensor, objects, velocities, drops, representatives.

    The readable summary leaves out the simulator's and sensor's full parameters; --json has everything.
    """
    from ..cli.show import show

    ds = _open(dataset)
    for obj in ds.objects:  # each bank read and checked against dataset.json: a bad one is said here
        for reducer in ds.reducers():
            ds.bank(obj, reducer)
    m = ds.meta
    if as_json:
        show({"name": ds.name, "path": str(ds.path), **m}, as_json=True)
        return
    prov = m.get("provenance", {})
    simulated = "simul" in str(prov.get("generator", "")).lower() or "synth" in str(prov.get("command", ""))
    objects = {}
    for obj in ds.objects:
        o = m["objects"][obj]
        vs = o.get("velocities_mps", [])
        rep = o.get("representative", {})
        manual = {round(x["velocity_mps"], 6) for x in rep.get("overrides", [])}
        objects[obj] = {
            "name": o.get("name", obj), "mass kg": o["mass_kg"],
            "drops": f"{len(vs)} velocities ({min(vs):g}-{max(vs):g} m/s) x {o.get('n_drops', '?')} drops" if vs else "none",
            "representative drop per velocity (medoid unless chosen by hand)": [
                f"{v:g} m/s #{c}" + (" (by hand)" if round(v, 6) in manual else "")
                for v, c in zip(vs, rep.get("chosen", []))],
        }
    show({
        "dataset": ds.name, "path": str(ds.path),
        "what": ("SIMULATED by the drop-rig simulator, not measured" if simulated
                 else "recorded or imported impacts"),
        "made by": prov.get("command", "-"),
        "raw rate": f"{ds.raw_rate_hz:g} Hz", "banks": f"{ds.rate_hz:g} Hz x {ds.n_samples} samples",
        "reducers": ds.reducers() or ["none"],
        "sensor": m.get("sensor", {}).get("model", "-"),
        "objects": objects,
        **({"note": note} if (note := few_drops(m)) else {}),
    }, as_json=False)


def pick(
    object: str = typer.Argument(..., help="Object id."),
    velocity: float = typer.Argument(..., help="Recorded velocity in m/s."),
    drop: Optional[int] = typer.Argument(None, help="Drop index to use; omit with --auto."),
    dataset: str = typer.Option(..., metavar="DIR", help="Dataset directory (rewritten in place, atomically)."),
    auto: bool = typer.Option(False, "--auto", help="Remove the manual choice and go back to the medoid."),
):
    """Choose the representative drop of one velocity by hand (stored in the metadata) and rebuild the banks."""
    from .build import set_representative

    if (drop is None) != auto:
        raise DatasetError("give either a DROP index or --auto")
    typer.echo(str(set_representative(Path(dataset), object, velocity, drop, progress=say)))


def tables(dataset: str = typer.Argument(..., help="Dataset directory (its tables/ folder is rewritten; not builtin:NAME).")):
    """Fit the ensemble and ensemble-warp interpolators to a dataset's drops and write their tables (one per reducer).

    `data synth`, `data import`, `data record` and `data pick` write them already; run this for a
    dataset written by an older hapticfx, so that effects load it without fitting.
    """
    from ..interpolators.fitted import write_tables
    from .dataset import BUILTIN_PREFIX, open_dataset

    ds = open_dataset(dataset)
    if dataset.startswith(BUILTIN_PREFIX):  # not the installed package's files
        raise DatasetError(f"{dataset}: ships with hapticfx, its tables fitted with it; to fit them again, copy it "
                           f"and give the copy: cp -r {ds.path} DIR && hapticfx data tables DIR")
    write_tables(ds, progress=say)


def bench_reducers(
    dataset: str = typer.Option(DEFAULT_DATASET, metavar="DATASET", help=DATASET_HELP),
    repeats: int = typer.Option(30, "--repeats", metavar="COUNT",
                                help="Timed repetitions (median and IQR are over these)."),
    number: int = typer.Option(200, metavar="COUNT", help="Calls per repetition for the single-signal time."),
    samples: int = typer.Option(1_000_000, metavar="COUNT", help="3-axis samples in the large-batch timing."),
):
    """Table 4 analogue (spectral/temporal match per object and reducer) and time per reduction."""
    from ..registry import get_registry
    from ..timing import table
    from ..bench.reducers import METRICS, score, time_reducers

    ds = _open(dataset)
    reg = get_registry()
    reducers = {name: reg.create("reducer", name) for name in ("dft321", "max-min")}
    scores = score(ds, reducers, progress=say)
    typer.echo(f"dataset {ds.name} ({ds.path}); metrics are means over all drops (not just representatives); "
               "definitions in docs/data.md")
    rows = []
    for s in scores:
        rows.append([s.object, s.n_drops] + [f"{s.mean[r, m]:.3f}" for r in reducers for m in ("spectral", "temporal")])
    typer.echo(table(["object", "drops", "DFT321 spectral", "DFT321 temporal", "max-min spectral", "max-min temporal"], rows))
    typer.echo("\nother views of the difference (spectral vs the RSS spectrum is 1 for DFT321 by construction):")
    rows = [[s.object] + [f"{s.mean[r, m]:.3f} ± {s.std[r, m]:.3f}" for r in reducers for m, _ in METRICS if m != "spectral"]
            for s in scores]
    typer.echo(table(["object"] + [f"{r} {m}" for r in reducers for m, _ in METRICS if m != "spectral"], rows))

    _, windows = ds.windows(ds.objects[0])
    signal = windows[0, 0]
    say(f"timing {', '.join(reducers)}")
    t = time_reducers(reducers, signal, n_big=samples, repeat=repeats, number=number)
    n_big = (samples // signal.shape[0]) * signal.shape[0]
    typer.echo(f"\ntime per reduction ({repeats} repetitions, reducers alternated; one signal: mean of {number} calls per "
               f"repetition; batch: {n_big} 3-axis samples as {n_big // signal.shape[0]} x {signal.shape[0]} x 3)")
    rows = []
    for what, label, unit, scale in (("one", f"one {signal.shape[0]}x3 signal", "us", 1e6), ("big", f"{n_big} samples", "ms", 1e3)):
        for r in reducers:
            tm = t[r, what]
            rows.append([label, r, f"{tm.median * scale:.2f} {unit}", f"{tm.iqr * scale:.2f} {unit}",
                         f"{min(tm.samples) * scale:.2f}-{max(tm.samples) * scale:.2f} {unit}"])
        ratio = t["max-min", what].median / t["dft321", what].median
        rows.append([label, "max-min / DFT321", f"{ratio:.2f}", "", ""])
    typer.echo(table(["input", "reducer", "median", "IQR", "min-max"], rows))


def register(bench: typer.Typer, data: typer.Typer) -> None:
    data.command("import")(import_)
    data.command("record")(record)
    data.command("plot")(plot)
    data.command("info")(info)
    data.command("pick")(pick)
    data.command("tables")(tables)
    bench.command("reducers")(bench_reducers)
