"""Warnings that can repeat thousands of times a second, logged at a bounded rate."""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable, Hashable


class RateLimitedLog:
    """Logs each kind of event at most once per ``interval_s``, with a count of those it held back.

    The first event of a ``key`` is logged at once (with its traceback, if
    ``exc_info`` is given; later ones never carry one). Events of the same key
    within ``interval_s`` are counted; the count goes out with the next line
    logged for that key, or with :meth:`flush`.
    """

    def __init__(self, logger: logging.Logger, *, interval_s: float = 5.0,
                 clock: Callable[[], float] = time.monotonic):
        self.logger = logger
        self.interval_s = float(interval_s)
        self.clock = clock
        self._lock = threading.Lock()
        self._keys: dict[Hashable, list] = {}  # key -> [last logged at, held back since, last message]

    def event(self, key: Hashable, message: str, *, exc_info: BaseException | None = None) -> None:
        now = self.clock()
        with self._lock:
            entry = self._keys.get(key)
            first = entry is None
            if not first and now - entry[0] < self.interval_s:
                entry[1] += 1
                entry[2] = message
                return
            held = 0 if first else entry[1]
            self._keys[key] = [now, 0, message]
        if held:
            message += f" ({held} more like it in the last {self.interval_s:g} s were not logged)"
        self.logger.warning(message, exc_info=exc_info if first else None)

    def flush(self) -> None:
        """Log the count of every event held back since its key was last logged."""
        with self._lock:
            held = [(entry[1], entry[2]) for entry in self._keys.values() if entry[1]]
            for entry in self._keys.values():
                entry[1] = 0
        for n, message in held:
            self.logger.warning("%s (and %d more like it, not logged)", message, n)
