"""Registration module of hapticfx-solenoid (entry point ``solenoid`` in group ``hapticfx``).

Only names and lazy references here: listing plugins must not import pyserial.
"""

from hapticfx.hookspecs import hookimpl
from hapticfx.registry import lazy


@hookimpl
def register_actuators(register):
    register("solenoid", lazy("hapticfx_solenoid.actuator:SolenoidActuator"))
