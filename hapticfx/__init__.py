"""hapticfx: haptic impact effects, from recorded drops to actuators.

Importing this package is cheap: it never imports torch, sounddevice or serial.
"""

from .errors import HapticfxError
from .interfaces import Actuator, ActuatorSpec, Impact, Interpolator, Model, Profile, Reducer, SafetyLimits
from .signal import Signal, valid_signal

__all__ = [
    "Actuator", "ActuatorSpec", "HapticfxError", "Impact", "Interpolator", "Model", "Profile",
    "Reducer", "SafetyLimits", "Signal", "valid_signal",
]
__version__ = "0.1.0"
