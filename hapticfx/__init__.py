"""hapticfx: haptic impact effects, from recorded drops to actuators.

Importing this package is cheap: it imports nothing until one of its names is asked for, and never
torch, sounddevice or serial. (That also lets the ``hapticfx`` command, :mod:`hapticfx.launch`, tell a
Ctrl-C during its start-up in one line.)
"""

from importlib import import_module

_HOMES = {
    "Actuator": "interfaces", "ActuatorSpec": "interfaces", "Impact": "interfaces", "Interpolator": "interfaces",
    "Model": "interfaces", "Profile": "interfaces", "Reducer": "interfaces", "SafetyLimits": "interfaces",
    "Engine": "engine", "HapticfxError": "errors", "Signal": "signal", "valid_signal": "signal",
}
__all__ = sorted(_HOMES)
__version__ = "0.1.0"


def __getattr__(name):
    if name in _HOMES:
        value = getattr(import_module(f".{_HOMES[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'hapticfx' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_HOMES))
