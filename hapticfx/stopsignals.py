"""SIGINT and SIGTERM as a request to stop, for a main thread that waits for one.

The handler only sets a flag. A handler that takes a lock (``threading.Event.set``,
the obvious choice) runs on the main thread, between two bytecodes of whatever it
was doing; when that was ``Event.wait`` on the same event, the main thread may hold
the event's lock, and the handler then waits for it forever. (A burst of signals
shows the handler running inside ``Condition.wait`` with that lock held; one
``hapticfx serve`` in a full test run did not exit within 20 s of its SIGTERM.)
"""

from __future__ import annotations

import signal
import time

POLL_S = 0.1  # how long a stop can go unnoticed by a waiting main thread


class StopSignals:
    """Notes SIGINT and SIGTERM while in a ``with`` block (main thread only); the previous handlers
    come back on exit."""

    def __init__(self):
        self.received: int | None = None  # the first signal that came
        self._previous: dict = {}

    def _note(self, signum, frame) -> None:
        if self.received is None:
            self.received = signum

    def __enter__(self) -> "StopSignals":
        self._previous = {s: signal.signal(s, self._note) for s in (signal.SIGINT, signal.SIGTERM)}
        return self

    def __exit__(self, *exc) -> bool:
        for s, handler in self._previous.items():
            signal.signal(s, handler)
        return False

    def wait(self, timeout: float | None = None) -> bool:
        """Sleep until a stop signal came (True) or ``timeout`` seconds passed (False; None: no limit)."""
        end = None if timeout is None else time.monotonic() + timeout
        while self.received is None:
            left = POLL_S if end is None else min(POLL_S, end - time.monotonic())
            if left <= 0:
                return False
            time.sleep(left)
        return True
