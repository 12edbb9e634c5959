"""Fixtures: the emulator on a real pseudo-terminal pair."""

from __future__ import annotations

import pytest

from hapticfx_solenoid.emulator import Firmware, PtyEmulator


@pytest.fixture
def emulator():
    """An emulator serving on a pty; ``emulator.port`` is the path pyserial opens."""
    with PtyEmulator(Firmware()) as emu:
        yield emu
