"""Fixtures: a real PulseAudio null sink (started by .ci/soundserver.sh) for the device tests.

Tests that need it take the ``soundserver`` fixture; without PulseAudio or
PortAudio installed they are skipped with the reason, never faked.
"""

from __future__ import annotations

import os

import pytest
from soundcard_server import start_soundserver, stop_soundserver, worker_runtime_dir


@pytest.fixture(scope="session")
def soundserver(request):
    """XDG_RUNTIME_DIR of the null-sink server, exported for this test process: the one scripts/test.sh
    started, or this pytest-xdist worker's own (stopped when the worker ends)."""
    own = worker_runtime_dir()
    xdg = start_soundserver(own)
    if own:
        request.addfinalizer(lambda: stop_soundserver(own))
    os.environ["XDG_RUNTIME_DIR"] = xdg
    try:
        import sounddevice  # noqa: F401  (PortAudio reads the server address when it opens a device)
    except OSError as exc:
        pytest.skip(f"PortAudio is not installed ({exc}): apt-get install -y libportaudio2")
    return xdg
