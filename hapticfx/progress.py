"""Progress of long work, in one style for every command: on standard error, never on the results.

On a terminal, :class:`Progress` redraws one line in place (label, bar, count, elapsed time, an
estimate of what is left, and a note); in a log (CI, a pipe) it writes a plain line at most every
``every_s`` seconds and one at the end. :func:`say` writes a status line. A worker process that shares
its terminal with others calls :func:`lines_only` so that its progress comes as plain lines too.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


_redraw = True


def lines_only() -> None:
    """From now on, progress in this process is written as plain lines, even on a terminal."""
    global _redraw
    _redraw = False


def say(message: str, *, stream: TextIO | None = None) -> None:
    """One status line on standard error."""
    out = stream or sys.stderr
    out.write(message + "\n")
    out.flush()


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 60}:{seconds % 60:02d}" if seconds >= 60 else f"{seconds} s"


class Progress:
    """``total`` steps of work called ``label``; use as a context manager and call :meth:`update`."""

    def __init__(self, total: int, label: str, *, unit: str = "", done: int = 0, stream: TextIO | None = None,
                 every_s: float = 5.0):
        self.total = max(int(total), 1)
        self.label = label
        self.unit = f" {unit}" if unit else ""
        self.done = done
        self.note = ""
        self.stream = stream or sys.stderr
        self.live = _redraw and bool(getattr(self.stream, "isatty", lambda: False)())
        self.every_s = every_s
        self._start = time.monotonic()
        self._first = done
        self._last_line = -float("inf")
        self._last_done: int | None = None
        self._width = 0

    def __enter__(self) -> "Progress":
        self._draw(force=self.live)
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def update(self, step: int = 1, *, note: str | None = None) -> None:
        """``step`` more steps done; ``note`` (a loss, what is running) is shown beside the count."""
        self.done = min(self.total, self.done + step)
        if note is not None:
            self.note = note
        self._draw()

    def say(self, message: str) -> None:
        """A status line, printed above the progress line."""
        if self.live:
            self.stream.write("\r" + " " * self._width + "\r")
        say(message, stream=self.stream)
        if self.live:
            self._draw(force=True)

    def close(self) -> None:
        self._draw(force=True, end=True)

    def text(self) -> str:
        elapsed = time.monotonic() - self._start
        rate_done = self.done - self._first
        left = f", ~{_clock(elapsed / rate_done * (self.total - self.done))} left" if 0 < rate_done and self.done < self.total else ""
        bar = ""
        if self.live:
            filled = int(20 * self.done / self.total)
            bar = "[" + "#" * filled + "." * (20 - filled) + "] "
        note = f"; {self.note}" if self.note else ""
        return f"{self.label}: {bar}{self.done}/{self.total}{self.unit} in {_clock(elapsed)}{left}{note}"

    def _draw(self, *, force: bool = False, end: bool = False) -> None:
        now = time.monotonic()
        if self.live:
            line = self.text()
            self.stream.write("\r" + line + " " * max(0, self._width - len(line)) + ("\n" if end else ""))
            self._width = len(line)
            self.stream.flush()
        elif self.done != self._last_done and (force or now - self._last_line >= self.every_s
                                                or self.done == self.total):
            self._last_line, self._last_done = now, self.done
            say(self.text(), stream=self.stream)
