"""The domain errors of hapticfx.

Every error a user can cause (a bad effect file, a missing dataset, an absent
device) is a :class:`HapticfxError`. The CLI turns exactly these into one line
and exit code 2; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import re
import reprlib

MAX_MESSAGE = 280  # characters: an error is one line a person reads

_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxdict, _REPR.maxlist, _REPR.maxtuple, _REPR.maxset = 2, 4, 4, 4, 4
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 40, 40, 24
_CONTROL = re.compile(r"[\x00-\x1f\x7f]+")


def preview(value) -> str:
    """A short one-line ``repr`` of a user's value, bounded however large or nested the value is."""
    return _CONTROL.sub(" ", _REPR.repr(value))


def one_line(text: str, limit: int = MAX_MESSAGE) -> str:
    """``text`` on one line (control characters and newlines as spaces), cut to ``limit`` characters."""
    flat = " ".join(_CONTROL.sub(" ", str(text)).split())
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


class HapticfxError(Exception):
    """A user-facing error: bad input, missing file, unavailable device.

    The message is one line of at most :data:`MAX_MESSAGE` characters, whatever it quotes.
    """

    def __init__(self, message: str, *, source: str | None = None, key: str | None = None):
        self.source = source
        self.key = key
        prefix = ""
        if source:
            prefix += f"{one_line(source, 120)}: "
        if key:
            prefix += f"{one_line(key, 60)}: "
        super().__init__(one_line(prefix + str(message)))


class SignalError(HapticfxError, ValueError):
    """A signal or numeric argument failed validation (NaN, wrong dtype, bad rate)."""


class EffectError(HapticfxError):
    """An effect or scene file is malformed."""


class PluginError(HapticfxError):
    """A plugin is unknown, duplicated, or failed to load."""


class DatasetError(HapticfxError):
    """A dataset is missing, corrupt or incomplete."""


class DeviceError(HapticfxError):
    """An actuator device failed, timed out, or cannot be used as configured."""


class DeviceUnavailable(DeviceError):
    """The device is not on this machine (no sound server, no output, no serial port).

    ``hapticfx play`` falls back to a WAV and PNG file for this error only: a device
    that is there but faulty is an error, not a reason to pretend it played.
    """


class CheckpointError(HapticfxError):
    """Model weights are missing, corrupt, or built for something else."""


class StudyError(HapticfxError):
    """A study file is malformed, or a results folder does not belong to it."""
