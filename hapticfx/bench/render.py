"""``hapticfx bench render``: render latency per effect file, stage by stage, with the effect's real actuator spec."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from ..errors import HapticfxError
from ..progress import Progress
from ..timing import Timing, ms, table

# The falling brick in every model the project ships, and a contact-model family.
def default_effects() -> list[Path]:
    """Every shipped effect: the falling objects in every model, then the contact-model families."""
    return sorted(Path("effects").glob("*.yaml")) + sorted(Path("effects/families").glob("*.yaml"))
STAGES = ("model", "shaping", "limiter", "whole render", "head: spread", "head: site limiters", "render + head")
HEAD_SCENE = Path("scenes/helmet_4.yaml")  # a head of four actuators, as the effects: from the repository root


class _Head:
    """The spatialiser of scenes/helmet_4.yaml (four sites) and one limiter per site, for one effect."""

    def __init__(self, pipeline):
        from ..safety import SafetyLimiter
        from ..scene import load_scene
        from ..spatial import Spatialiser

        self.spatialiser = Spatialiser(load_scene(HEAD_SCENE).head)
        self.limiters = [SafetyLimiter(pipeline.limits, pipeline.actuator.spec.rate_hz)
                         for _ in self.spatialiser.layout.sites]


def _time_stages(pipeline, velocity: float, head: _Head, point) -> tuple[float, ...]:
    """Seconds of model, shaping and limiter for one impact, and of ``Pipeline.render`` itself; then of what a
    head of four actuators adds: the spatialiser (placement, gains, a row per site) and the limiter of each site.

    As the pipeline renders: a model that answers with terms is timed for them and its
    profile, and shaping is the sum of its shaped atoms; any other is shaped per impact.
    """
    from ..interfaces import Impact
    from ..shaping import shape

    impact = Impact(pipeline.effect.object_id, velocity)
    t0 = time.perf_counter()
    terms = pipeline.model.terms(impact)
    profile = pipeline.model.render(impact) if terms is None else terms.profile()
    t1 = time.perf_counter()
    if terms is None:
        shaped = shape(profile, pipeline.actuator.spec, gain=pipeline.gain, scale=pipeline.scale)
    else:
        shaped = pipeline.atoms.shape(terms, pipeline.actuator.spec)
    t2 = time.perf_counter()
    limited = pipeline.limiter.process(shaped.samples)
    t3 = time.perf_counter()
    pipeline.render(Impact(impact.object, velocity * (1 + 1e-9)))  # a velocity no model has cached yet
    t4 = time.perf_counter()
    placements = head.spatialiser.place(point)
    rows = head.spatialiser.spread(limited, shaped.rate_hz, placements)
    t5 = time.perf_counter()
    for p in placements:  # as the engine: the sounding sites' limiters (a silent row needs none)
        if p.gain > 0:
            head.limiters[p.site].process(rows[p.site])
    t6 = time.perf_counter()
    return t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4, t6 - t5, (t4 - t3) + (t6 - t4)


def render(
    effects: Optional[list[Path]] = typer.Argument(None, help="Effect files (default: every shipped effect, the "
                                                  "falling objects in every model and the impact families)."),
    repeats: int = typer.Option(200, "--repeats", metavar="COUNT", min=5, help="Timed renders per effect."),
    direct: bool = typer.Option(True, "--direct/--no-direct", help="Also time the ConvBiLSTM by direct inference "
                                "(needs torch)."),
):
    """Render latency per impact with each effect's own actuator spec (rate, band, limits): the model, shaping
    and the safety limiter timed apart, and the whole `Pipeline.render`; then what a head of four actuators adds
    (the spatialiser and a limiter per actuator); median and p99, ratios to the first."""
    from ..pipeline import Pipeline

    paths = [Path(p) for p in (effects or default_effects())]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise HapticfxError(f"effect file(s) not found: {', '.join(missing)} (run from the repository root or "
                            "name the files)")
    if not HEAD_SCENE.is_file():
        raise HapticfxError(f"{HEAD_SCENE} not found: run from the repository root")
    pipelines = {str(p): Pipeline.from_effect(p, device="memory") for p in paths}
    if direct and effects is None:
        import dataclasses

        from ..effect import load_effect

        e = load_effect(Path("effects/falling_brick_convbilstm.yaml"))
        e = dataclasses.replace(e, model=dataclasses.replace(
            e.model, options={**e.model.options, "interpolator_options": {"cache": False}}))
        try:
            pipelines["effects/falling_brick_convbilstm.yaml, cache: false"] = Pipeline(e, device="memory")
        except HapticfxError as exc:
            typer.echo(f"skipped direct ConvBiLSTM inference: {exc}", err=True)
    # A fresh velocity for every render (no per-velocity cache can answer it); effects take turns, so a change
    # in machine load falls on all of them alike.
    for pipeline in pipelines.values():
        pipeline.warm()  # as opening does
    rng = np.random.default_rng(0)
    velocities = rng.uniform(2.45, 5.2, size=repeats + 5)
    points = rng.normal(size=(repeats + 5, 3))
    points[:, 2] = np.abs(points[:, 2])  # anywhere on the upper half of the head
    heads = {label: _Head(pipeline) for label, pipeline in pipelines.items()}
    times: dict[str, list[tuple]] = {label: [] for label in pipelines}
    with Progress(len(velocities), "render", unit="rounds (5 warm-up)") as bar:
        for i, v in enumerate(velocities):
            for label, pipeline in pipelines.items():
                stages = _time_stages(pipeline, float(v) * pipeline.effect.velocity_mps / 3.8, heads[label],
                                      tuple(points[i]))
                if i >= 5:  # the first five are warm-up
                    times[label].append(stages)
            bar.update()
    rows, base = [], None
    for label, samples in times.items():
        pipeline = pipelines[label]
        spec = pipeline.actuator.spec
        cols = [Timing(tuple(s[k] for s in samples)) for k in range(len(STAGES))]
        base = base or cols[3].median
        rows.append([label, f"{pipeline.plan.effect.actuator.type} {spec.rate_hz:g} Hz"]
                    + [f"{ms(c.median)} / {ms(c.p99)}" for c in cols] + [f"{cols[3].median / base:.2f}"])
    typer.echo(f"render latency per impact, {repeats} renders per effect, interleaved; velocities uniform over "
               "[0.64, 1.37] x each effect's own (a new one each render); median / p99 in ms. head: what "
               f"{HEAD_SCENE.name}'s four actuators add (the spatialiser, at a point anywhere on the upper half "
               "of the head, and a limiter per actuator); render + head: whole render + both")
    typer.echo(table(["effect", "actuator", *STAGES, "x first"], rows))


def register(bench: typer.Typer) -> None:
    bench.command("render")(render)
