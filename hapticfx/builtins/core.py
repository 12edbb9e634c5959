"""Built-in core plugin: the models, interpolator, actuators and commands every install has."""

from __future__ import annotations

from ..hookspecs import hookimpl
from ..registry import lazy


@hookimpl
def register_models(register):
    register("kinetic-energy", lazy("hapticfx.models.kinetic:KineticEnergyModel"))
    register("data-driven", lazy("hapticfx.models.datadriven:DataDrivenModel"))


@hookimpl
def register_interpolators(register):
    register("linear", lazy("hapticfx.interpolators.linear:LinearInterpolator"))
    register("ensemble", lazy("hapticfx.interpolators.ensemble:EnsembleInterpolator"))
    register("ensemble-warp", lazy("hapticfx.interpolators.ensemble_warp:EnsembleWarpInterpolator"))


@hookimpl
def register_actuators(register):
    register("wav", lazy("hapticfx.actuators.virtual:WavActuator"))
    register("csv", lazy("hapticfx.actuators.virtual:CsvActuator"))
    register("memory", lazy("hapticfx.actuators.virtual:MemoryActuator"))


@hookimpl
def register_commands(app, bench):
    from ..bench import ceiling, fuzz, interpolators, render, startup, texture
    from ..cli import commands

    commands.register(app)
    render.register(bench)
    interpolators.register(bench)
    ceiling.register(bench)
    texture.register(bench)
    startup.register(bench)
    fuzz.register(bench)
