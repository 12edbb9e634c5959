"""Core commands: play, render, validate, info, plugins, schema."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from ..errors import DeviceUnavailable, HapticfxError
from .show import JSON_HELP, show

VELOCITY_HELP = "Impact velocity in m/s (default: the effect's velocity_mps)."
OBJECT_HELP = "Object id (default: the effect's object)."
HAPTIC_FILE_HELP = "or a haptic file (.haptic, .ahap, .android.json, .ogg, .hjif: docs/formats.md)."


def _device(value: Optional[str]):
    """A --device value: an index when it is a number, else a name or wav:PATH / csv:PATH / memory."""
    if value is None:
        return None
    return int(value) if value.strip().isdigit() else value


FORCE_HELP = "Replace an output file that hapticfx did not write (its own WAV, PNG and CSV files are replaced anyway)."


def _velocity_applies(pipeline, velocity: Optional[float]) -> None:
    """Refuse a --velocity the effect would ignore (a haptic file played as recorded), rather than say it played."""
    if velocity is not None and getattr(pipeline.model, "plays_as_recorded", False):
        raise HapticfxError(f"{pipeline.effect.source}: plays as recorded at any velocity, so --velocity does not "
                            "apply; to scale it by velocity, give an effect with model: {type: haptic-file, file: ..., "
                            "reference_velocity_mps: V}")


def _write_outputs(pipeline, delivery, outs: list[Path], *, force: bool) -> list[Path]:
    """Write a delivery to each of ``outs`` by its suffix (.wav, .csv, .png), all of them or none; returns them."""
    from ..actuators.files import check_overwrite
    from ..atomic import together

    for out in outs:
        check_overwrite(out, force=force)
    with together(outs):
        return [_write_output(pipeline, delivery, out) for out in outs]


def _write_output(pipeline, delivery, out: Path) -> Path:
    from ..actuators.files import CSV_HEADERS, write_csv, write_wav
    from .figures import impact_png

    suffix = out.suffix.lower()
    if suffix == ".wav":
        return write_wav(out, delivery.output.samples, delivery.output.rate_hz)
    if suffix == ".csv":
        units = getattr(pipeline.model, "units", "g")
        header = CSV_HEADERS[0] if units == "g" else CSV_HEADERS[1]
        time_column, column = header.split(",")
        return write_csv(out, {time_column: delivery.profile.times(), column: delivery.profile.samples})
    if suffix == ".png":
        return impact_png(out, delivery, title=pipeline.effect.name, profile_units=getattr(pipeline.model, "units", "g"),
                          volts_peak=pipeline.actuator.spec.volts_peak)
    raise HapticfxError(f"{out}: unknown output type {suffix!r}; use .wav, .csv or .png")


def _warn(delivery) -> None:
    for note in delivery.notes:
        typer.echo(f"hapticfx: warning: {note}", err=True)


def _summary(pipeline, delivery, destination: str) -> str:
    imp, out = delivery.impact, delivery.output
    return (f"{pipeline.effect.name}: {imp.object} at {imp.velocity:.2f} m/s -> {destination}; "
            f"{out.duration_s * 1000:.0f} ms at {out.rate_hz:g} Hz, peak {out.peak:.3f} of full scale; "
            f"{delivery.limiter.summary()}")


def play(
    effect: Path = typer.Argument(..., help=f"Effect file (YAML), e.g. effects/falling_brick.yaml, {HAPTIC_FILE_HELP}"),
    velocity: Optional[float] = typer.Option(None, "--velocity", "-v", metavar="M/S", help=VELOCITY_HELP),
    object: Optional[str] = typer.Option(None, "--object", metavar="OBJECT", help=OBJECT_HELP),
    device: Optional[str] = typer.Option(
        None, "--device", "-d", metavar="DEVICE",
        help="Output device: a name or index for the effect's actuator, 'wav:PATH' or 'csv:PATH' to write a "
             "WAV or CSV file at the actuator's rate, or 'memory'. Default: the effect's device.",
    ),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
):
    """Render one impact and play it on the effect's actuator.

    With no output device available (a headless machine), the impact is written to a WAV
    file and a PNG picture in the current directory instead, and their names are printed.
    """
    from ..atomic import file_name_part
    from ..pipeline import Pipeline

    dev = _device(device)
    pipeline = Pipeline.from_effect(effect, device=dev, overwrite=force)
    _velocity_applies(pipeline, velocity)
    try:
        pipeline.open()
    except DeviceUnavailable as exc:
        if dev is not None:
            raise
        stem = f"hapticfx-{file_name_part(pipeline.effect.name)}-{(velocity if velocity is not None else pipeline.effect.velocity_mps):.2f}mps"
        wav, png = Path(f"{stem}.wav"), Path(f"{stem}.png")
        delivery = pipeline.render(velocity=velocity, object=object)
        _warn(delivery)
        _write_outputs(pipeline, delivery, [wav, png], force=force)
        typer.echo(f"no output device ({exc}); wrote the impact to {wav} and {png} instead "
                   f"(choose a file with --device wav:PATH)")
        return
    try:
        delivery = pipeline.impact(velocity=velocity, object=object)
        _warn(delivery)
        pipeline.actuator.wait(timeout=delivery.output.duration_s + 2.0)
        where = pipeline.actuator.describe()  # while open: how it plays, too
    finally:
        pipeline.close()
    typer.echo(_summary(pipeline, delivery, where))


def render(
    effect: Path = typer.Argument(..., help=f"Effect file (YAML) {HAPTIC_FILE_HELP}"),
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE",
                             help="Output file: .wav (actuator signal), .csv (profile) or .png (both, plotted)."),
    velocity: Optional[float] = typer.Option(None, "--velocity", "-v", metavar="M/S", help=VELOCITY_HELP),
    object: Optional[str] = typer.Option(None, "--object", metavar="OBJECT", help=OBJECT_HELP),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
):
    """Render one impact to a file without touching any device."""
    from ..pipeline import Pipeline

    pipeline = Pipeline.from_effect(effect, device="memory")
    _velocity_applies(pipeline, velocity)
    delivery = pipeline.render(velocity=velocity, object=object)
    _warn(delivery)
    written = _write_outputs(pipeline, delivery, [out], force=force)
    typer.echo(_summary(pipeline, delivery, ", ".join(map(str, written))))


def _yaml_kind(data) -> str:
    """'scene', 'study' or 'effect': what a parsed YAML file holds, by its top-level keys."""
    if isinstance(data, dict) and "model" not in data:
        if "tasks" in data or "stimuli" in data:
            return "study"
        if "effects" in data or "actuators" in data:
            return "scene"
    return "effect"


def _validate_one(file: Path) -> tuple[str, str]:
    """Load ``file`` as the command that takes it would, short of opening a device: (kind, summary).

    A YAML file is parsed once, then built as what its keys say it is; a haptic file stands for an effect."""
    from ..effect import effect_from_mapping, load_effect, read_yaml
    from ..interfaces import Impact
    from ..pipeline import Pipeline

    if file.suffix.lower() not in (".yaml", ".yml"):
        kind, effect = "effect", load_effect(file)
    else:
        data, where = read_yaml(file), {"source": str(file), "base_dir": file.resolve().parent}
        kind = _yaml_kind(data)
        if kind == "scene":  # as `serve` and hapticfx.Engine load it: every entry's pipeline built
            from ..scene import scene_from_mapping

            scene = scene_from_mapping(data, **where)
            for entry in scene.entries.values():
                Pipeline(entry.effect)
            outputs = len({entry.output for entry in scene.entries.values()})
            return kind, f"scene {scene.name!r}: {len(scene.entries)} objects on {outputs} output(s)"
        if kind == "study":  # as `study check`: the study, its effects and a participant's schedule
            from ..study.schedule import build_schedule
            from ..study.spec import study_from_mapping

            study = study_from_mapping(data, **where)
            build_schedule(study, "P01")
            return kind, f"study {study.name!r}: {len(study.stimuli)} stimuli, {len(study.tasks)} tasks"
        effect = effect_from_mapping(data, **where)
    pipeline = Pipeline.from_effect(effect)
    e = pipeline.effect
    for note in pipeline.model.notes(Impact(e.object_id, e.velocity_mps)):  # a haptic file's legacy form, say
        typer.echo(f"hapticfx: warning: {note}", err=True)
    return kind, f"effect {e.name!r}: model {e.model.type}, actuator {e.actuator.type}"


def validate(
    files: list[Path] = typer.Argument(..., help="Effect, scene or study files, or haptic files, to check."),
    as_json: bool = typer.Option(False, "--json", help=JSON_HELP),
):
    """Check effect, scene and study files (and haptic files: .haptic, .ahap, ...) as `play`, `serve` and
    `study run` would load them, short of opening a device; keys, types, ranges, plugins and their parameters,
    the dataset, object, reducer, interpolator and its options, weights or tables, and the limits against the
    actuator's hard limits. A YAML file is a scene when it has `effects` or `actuators` and no `model`, a
    study when it has `tasks` or `stimuli`. Exit 2 if any fails."""
    results = []
    for file in files:
        try:
            kind, summary = _validate_one(file)
            results.append({"file": str(file), "ok": True, "kind": kind, "summary": summary})
            if not as_json:
                typer.echo(f"ok: {file} ({summary})")
        except HapticfxError as exc:
            results.append({"file": str(file), "ok": False, "error": str(exc)})
            typer.echo(f"hapticfx: error: {exc}", err=True)
    if as_json:
        typer.echo(json.dumps(results, indent=2))
    if not all(r["ok"] for r in results):
        raise typer.Exit(2)


def info(
    effect: Path = typer.Argument(..., help="Effect file (YAML)."),
    device: Optional[str] = typer.Option(None, "--device", "-d", metavar="DEVICE", help="As for play."),
    as_json: bool = typer.Option(False, "--json", help=JSON_HELP),
):
    """Show what an effect will load: plugins, dataset, interpolator, actuator spec and limits."""
    from ..pipeline import Pipeline

    pipeline = Pipeline.from_effect(effect, device=_device(device))
    show(pipeline.describe(), as_json=as_json)


def plugins(as_json: bool = typer.Option(False, "--json", help=JSON_HELP)):
    """List installed plugins and what each registers (name, kind, distribution, version)."""
    from ..registry import get_registry

    reg = get_registry()
    rows = [(r.kind, r.name, r.plugin, r.distribution, r.version) for r in reg]
    used = {r[2] for r in rows}
    rows += [("-", "-", p.name, p.distribution, p.version) for p in reg.plugins.values() if p.name not in used]
    header = ("kind", "name", "plugin", "distribution", "version")
    if as_json:  # a plugin that registers nothing has kind and name null
        typer.echo(json.dumps([{k: (None if v == "-" and k in ("kind", "name") else v) for k, v in zip(header, row)}
                               for row in rows], indent=2))
        return
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows)]
    for row in (header, *rows):
        typer.echo("  ".join(str(x).ljust(w) for x, w in zip(row, widths)).rstrip())


def schema(out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="FILE",
                                              help="Write to this file instead of stdout."),
           force: bool = typer.Option(False, "--force", help="Replace an output file that hapticfx did not write "
                                      "(a schema it wrote is replaced anyway).")):
    """Print the JSON Schema of effect files (for editors), covering the installed plugins."""
    from ..actuators.files import check_overwrite
    from ..atomic import atomic_path
    from ..schema import effect_schema

    if out is not None:
        check_overwrite(out, force=force)
    text = json.dumps(effect_schema(), indent=2, sort_keys=True) + "\n"
    if out is None:
        typer.echo(text, nl=False)
        return
    with atomic_path(out) as tmp:
        tmp.write_text(text)
    typer.echo(f"wrote {out}")


def register(app: typer.Typer) -> None:
    for fn in (play, render, validate, info, plugins, schema):
        app.command(fn.__name__)(fn)

