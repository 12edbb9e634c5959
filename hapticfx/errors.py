"""The domain errors of hapticfx.

Every error a user can cause (a bad effect file, a missing dataset, an absent
device) is a :class:`HapticfxError`. The CLI turns exactly these into one line
and exit code 2; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations


class HapticfxError(Exception):
    """A user-facing error: bad input, missing file, unavailable device."""

    def __init__(self, message: str, *, source: str | None = None, key: str | None = None):
        self.source = source
        self.key = key
        prefix = ""
        if source:
            prefix += f"{source}: "
        if key:
            prefix += f"{key}: "
        super().__init__(prefix + message)


class SignalError(HapticfxError, ValueError):
    """A signal or numeric argument failed validation (NaN, wrong dtype, bad rate)."""


class EffectError(HapticfxError):
    """An effect or scene file is malformed."""


class PluginError(HapticfxError):
    """A plugin is unknown, duplicated, or failed to load."""


class DatasetError(HapticfxError):
    """A dataset is missing, corrupt or incomplete."""


class DeviceError(HapticfxError):
    """An actuator device is absent, failed or timed out."""


class CheckpointError(HapticfxError):
    """Model weights are missing, corrupt, or built for something else."""


class StudyError(HapticfxError):
    """A study file is malformed, or a results folder does not belong to it."""
