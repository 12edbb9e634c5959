"""SIGINT/SIGTERM as a stop request for a waiting main thread (``hapticfx serve``, the solenoid emulator)."""

import os
import signal
import threading
import time

import pytest

from hapticfx.stopsignals import POLL_S, StopSignals


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_ends_the_wait_and_the_previous_handlers_come_back(signum):
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with StopSignals() as stop:
        threading.Timer(0.2, os.kill, (os.getpid(), signum)).start()
        t0 = time.monotonic()
        assert stop.wait() is True
        assert 0.15 < time.monotonic() - t0 < 0.2 + 2 * POLL_S + 0.3
        assert stop.received == signum
    assert {s: signal.getsignal(s) for s in before} == before


def test_without_a_signal_the_wait_ends_at_its_timeout():
    with StopSignals() as stop:
        t0 = time.monotonic()
        assert stop.wait(0.25) is False
        assert 0.25 <= time.monotonic() - t0 < 0.25 + POLL_S + 0.3
        assert stop.received is None


def test_the_handler_takes_no_lock_while_the_main_thread_is_busy():
    """A burst of signals while the main thread runs Python code: each handler call returns at once (one
    that took a lock held by the main thread would never return, and this test would hang)."""
    with StopSignals() as stop:
        sender = threading.Thread(target=lambda: [os.kill(os.getpid(), signal.SIGTERM) for _ in range(2000)])
        sender.start()
        while sender.is_alive():
            stop.wait(0)
        sender.join()
        assert stop.received == signal.SIGTERM
