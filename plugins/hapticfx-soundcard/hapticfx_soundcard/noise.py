"""Keeping PortAudio's and ALSA's diagnostics off the terminal while a sound stream runs.

When a sound server dies or is restarted, PortAudio and the ALSA library each
print several lines to the process's standard error (file descriptor 2,
below Python) for every failed poll and every attempt to reopen: dozens of
lines for one outage. :class:`NoiseFilter` puts a pipe on descriptor 2 while
sound streams are open; a thread forwards everything to the real standard
error except those diagnostic lines, which it counts. When the last stream
closes, descriptor 2 is restored and one line says how many were hidden.
Set ``HAPTICFX_DEVICE_NOISE=show`` to leave standard error alone.
"""

from __future__ import annotations

import os
import re
import sys
import threading

NOISE = re.compile(rb"^(Expression '.*' failed in 'src/|ALSA lib |PaAlsa|Cannot connect to server|jack server)")
# What may begin a noise line: a partial line that could still become one is held until its end.
_PREFIXES = (b"Expression '", b"ALSA lib ", b"PaAlsa", b"Cannot connect to server", b"jack server")


def _may_become_noise(partial: bytes) -> bool:
    return any(p.startswith(partial[: len(p)]) for p in _PREFIXES)


class NoiseFilter:
    """Descriptor 2 through a pipe, minus PortAudio/ALSA diagnostics; reference-counted."""

    def __init__(self, *, fd: int = 2):
        self.fd = fd
        self.hidden = 0
        self.first: bytes | None = None
        self._last_was_noise = False
        self._users = 0
        self._lock = threading.Lock()
        self._saved: int | None = None
        self._thread: threading.Thread | None = None

    @staticmethod
    def wanted() -> bool:
        return os.environ.get("HAPTICFX_DEVICE_NOISE", "").lower() != "show"

    def acquire(self) -> None:
        """Start filtering (the first user); later users only count."""
        with self._lock:
            self._users += 1
            if self._users > 1 or self._saved is not None or not self.wanted():
                return
            try:
                sys.stderr.flush()
            except (AttributeError, ValueError, OSError):
                pass
            read_end, write_end = os.pipe()
            self._saved = os.dup(self.fd)
            os.dup2(write_end, self.fd)
            os.close(write_end)
            self._thread = threading.Thread(target=self._pump, args=(read_end, self._saved),
                                            name="hapticfx-soundcard-stderr", daemon=True)
            self._thread.start()

    def release(self) -> None:
        """Stop filtering when the last user leaves; says in one line what was hidden."""
        with self._lock:
            self._users = max(0, self._users - 1)
            if self._users or self._saved is None:
                return
            saved, self._saved = self._saved, None
            try:
                sys.stderr.flush()
            except (AttributeError, ValueError, OSError):
                pass
            os.dup2(saved, self.fd)  # the pipe's last write end closes: the pump reads to its end
            thread = self._thread
        if thread is not None:
            thread.join(timeout=5.0)  # it forwards what is still in the pipe, then sees its end
        alive = thread is not None and thread.is_alive()  # a child process still holds the pipe
        if self.hidden:
            first = (self.first or b"").decode("utf-8", "replace").strip()[:100]
            os.write(self.fd, (f"hapticfx-soundcard: hid {self.hidden} line(s) of PortAudio/ALSA diagnostics "
                               f"(first: {first!r}); HAPTICFX_DEVICE_NOISE=show shows them\n").encode())
            self.hidden, self.first = 0, None
        if not alive:  # else the pump still forwards the child's output through it
            os.close(saved)

    def _pump(self, read_end: int, out: int) -> None:
        pending = b""
        continuing = False  # the start of the current line was already forwarded: its rest is not a diagnostic
        try:
            while True:
                chunk = os.read(read_end, 65536)
                if not chunk:
                    break
                pending += chunk
                *lines, pending = pending.split(b"\n")
                passed = []
                for line in lines:
                    if continuing or not self._noise(line):
                        passed.append(line + b"\n")
                    continuing = False
                if pending and (continuing or not _may_become_noise(pending)):
                    passed.append(pending)  # a progress line ("\r...") goes out at once
                    pending = b""
                    continuing = True
                    self._last_was_noise = False
                if passed:
                    os.write(out, b"".join(passed))
            if pending and not self._noise(pending):
                os.write(out, pending)
        except OSError:
            pass  # the real standard error is gone; nothing left to forward to
        finally:
            os.close(read_end)

    def _noise(self, line: bytes) -> bool:
        if NOISE.match(line):
            self.hidden += 1
            self.first = self.first or line
            self._last_was_noise = True
            return True
        if not line.strip() and self._last_was_noise:  # ALSA ends its messages with an empty line
            return True
        self._last_was_noise = False
        return False


FILTER = NoiseFilter()
