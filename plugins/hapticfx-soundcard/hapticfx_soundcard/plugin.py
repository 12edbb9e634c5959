"""Registration of the sound-card plugin; imports neither sounddevice nor the actuators."""

from hapticfx.hookspecs import hookimpl
from hapticfx.registry import lazy


@hookimpl
def register_actuators(register):
    register("vibro-transducer", lazy("hapticfx_soundcard.actuator:VibroTransducer"))
    register("haptuator", lazy("hapticfx_soundcard.actuator:Haptuator"))


@hookimpl
def register_commands(app, bench):
    from .commands import add_commands

    add_commands(app, bench)
