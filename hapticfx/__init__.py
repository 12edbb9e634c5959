"""hapticfx: haptic impact effects, from recorded drops to actuators.

Importing this package is cheap: it never imports torch, sounddevice or serial.
"""

from .errors import HapticfxError
from .interfaces import Actuator, ActuatorSpec, Impact, Interpolator, Model, Profile, Reducer, SafetyLimits
from .signal import Signal, valid_signal

__all__ = [
    "Actuator", "ActuatorSpec", "Engine", "HapticfxError", "Impact", "Interpolator", "Model", "Profile",
    "Reducer", "SafetyLimits", "Signal", "valid_signal",
]
__version__ = "0.1.0"


def __getattr__(name):
    # Engine pulls in threads and the pipeline; import it only when asked for.
    if name == "Engine":
        from .engine import Engine

        return Engine
    raise AttributeError(f"module 'hapticfx' has no attribute {name!r}")
