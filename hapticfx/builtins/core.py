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


@hookimpl
def register_actuators(register):
    register("wav", lazy("hapticfx.actuators.virtual:WavActuator"))
    register("memory", lazy("hapticfx.actuators.virtual:MemoryActuator"))


@hookimpl
def register_commands(app, bench):
    from ..cli import bench_fuzz, bench_interpolators, bench_render, bench_startup, commands

    commands.register(app)
    bench_render.register(bench)
    bench_interpolators.register(bench)
    bench_startup.register(bench)
    bench_fuzz.register(bench)
