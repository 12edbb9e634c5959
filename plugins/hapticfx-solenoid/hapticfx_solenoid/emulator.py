"""A Python stand-in for the solenoid board: the sketch's logic behind a pseudo-terminal.

``Firmware`` is the sketch's command handling (same replies, same limits,
same on-time book-keeping); ``PtyEmulator`` serves it on the master side of a
``pty.openpty()`` pair so that a host opens the slave path with pyserial,
exactly as it opens ``/dev/ttyACM0``. For users without a board::

    python -m hapticfx_solenoid.emulator --link /tmp/solenoid
    hapticfx play effects/falling_brick.yaml --device /tmp/solenoid   # effect with actuator type: solenoid

``--fault silent|garbage|babble|close`` makes it misbehave, for fault tests.
"""

from __future__ import annotations

import argparse
import os
import pty
import select
import sys
import termios
import threading
import time
import tty
from dataclasses import dataclass
from typing import Callable, Literal

from hapticfx.stopsignals import StopSignals

from .protocol import MAX_LINE, PROTOCOL_VERSION, PULSE_GAP_MS, DutyWindow, FirmwareLimits

EMULATOR_ID = "hapticfx-solenoid-emulator/1.0"
FaultKind = Literal["silent", "garbage", "babble", "close"]
FAULTS: tuple[str, ...] = ("silent", "garbage", "babble", "close")
# Not ASCII, control characters, and a newline: whatever a wrong baud rate or another device sends.
GARBAGE = b"\xfe\x00\x9cPO\xffNG\x1b[0m\x07\r\n"


def _millis() -> int:
    return int(time.monotonic() * 1000)


class Firmware:
    """The sketch's command handling, one line in, at most one reply line out."""

    def __init__(self, limits: FirmwareLimits = FirmwareLimits(), *, clock: Callable[[], int] = _millis,
                 firmware_id: str = EMULATOR_ID):
        self.limits = limits
        self.clock = clock
        self.firmware_id = firmware_id
        self.window = DutyWindow(limits.budget_ms, limits.window_ms)
        self.on_until: int | None = None
        self.duty = 0
        self.run: tuple[int, int] | None = None  # (start, planned end ms) of the current run of pulses
        self.fired = 0
        self.refused = 0
        self.pulses: list[tuple[int, int, int]] = []  # (start ms, on ms, duty): what the coil did

    def is_on(self, now: int) -> bool:
        if self.on_until is not None and now >= self.on_until:
            self.on_until = None
            self.duty = 0
        return self.on_until is not None

    def handle(self, line: str) -> str | None:
        """The reply to one command line (without its ending), or None for an empty line."""
        now = self.clock()
        self.is_on(now)
        line = line.replace("\r", "")
        if len(line) > MAX_LINE:
            return self._refuse("TOOLONG", f"line longer than {MAX_LINE} bytes")
        words = [word for word in line.split(" ") if word]
        if not words:
            return None
        command, args = words[0], words[1:]
        if command == "PING" and not args:
            return f"PONG {PROTOCOL_VERSION} {self.firmware_id}"
        if command == "STATUS" and not args:
            return self._status(now)
        if command == "STOP" and not args:
            self.on_until, self.duty = None, 0
            return "OK STOP"
        if command == "FIRE":
            return self._fire(args, now)
        return self._refuse("SYNTAX", "unknown command")

    def _fire(self, args: list[str], now: int) -> str:
        if len(args) != 2 or not all(a.isdigit() and len(a) <= 5 for a in args):
            return self._refuse("SYNTAX", "usage FIRE <ms> <duty>")
        on_ms, duty = int(args[0]), int(args[1])
        if on_ms < 1 or duty > 255:
            return self._refuse("RANGE", "ms >= 1, duty 0..255")
        if on_ms > self.limits.max_on_ms:
            return self._refuse("LIMIT", f"max on-time {self.limits.max_on_ms} ms")
        if self.is_on(now):
            return self._refuse("BUSY", f"pulse on for {self.on_until - now} ms")
        # a pulse less than PULSE_GAP_MS after the last one's planned end (a STOP may have ended it sooner:
        # counting to its plan is the stricter) continues its run
        run = self.run is not None and now - self.run[1] < PULSE_GAP_MS
        if run and on_ms > (left := max(0, self.limits.max_on_ms - (now - self.run[0]))):
            return self._refuse("LIMIT", f"{left} ms on-time left in this run")
        available = self.window.available_ms(now)
        if on_ms > available:
            return self._refuse("DUTY", f"{available} ms left in window")
        self.window.book(now, on_ms)
        self.run = (self.run[0] if run else now, now + on_ms)
        self.on_until, self.duty = now + on_ms, duty
        self.fired += 1
        self.pulses.append((now, on_ms, duty))
        return f"OK FIRE {on_ms} {duty}"

    def _refuse(self, code: str, text: str) -> str:
        self.refused += 1
        return f"ERR {code} {text}"

    def _status(self, now: int) -> str:
        lim = self.limits
        return (
            f"STATUS on={int(self.is_on(now))} used_ms={self.window.used_ms(now)} budget_ms={lim.budget_ms} "
            f"max_on_ms={lim.max_on_ms} duty_permille={lim.duty_permille} window_ms={lim.window_ms} "
            f"fired={self.fired} refused={self.refused}"
        )


@dataclass(frozen=True)
class Fault:
    """Misbehaviour after ``after`` well-answered lines: ``silent``, ``garbage``, ``babble`` or ``close``."""

    kind: FaultKind
    after: int = 0

    def __post_init__(self):
        if self.kind not in FAULTS or self.after < 0:
            raise ValueError(f"fault must be one of {', '.join(FAULTS)} with after >= 0, got {self.kind!r}, {self.after}")


def open_raw_pty() -> tuple[int, int, str]:
    """A pseudo-terminal pair with the slave in raw mode (no echo): (master fd, slave fd, slave path)."""
    master, slave = pty.openpty()
    tty.setraw(slave, termios.TCSANOW)
    return master, slave, os.ttyname(slave)


class PtyEmulator:
    """Serves :class:`Firmware` on a pseudo-terminal, in a background thread.

    ``port`` is the path a host opens with ``serial.Serial``. Use as a context
    manager, or ``start()`` / ``stop()``.
    """

    def __init__(self, firmware: Firmware | None = None, *, fault: Fault | None = None):
        self.firmware = firmware or Firmware()
        self.fault = fault
        self.master, self.slave, self.port = open_raw_pty()
        self.lines_seen = 0
        self._stop_r, self._stop_w = os.pipe()
        self._thread = threading.Thread(target=self.serve, name="solenoid-emulator", daemon=True)

    def start(self) -> "PtyEmulator":
        self._thread.start()
        return self

    def stop(self) -> None:
        if self._stop_w >= 0:
            os.write(self._stop_w, b"x")
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        for fd in (self._stop_r, self._stop_w, self.master, self.slave):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._stop_r = self._stop_w = self.master = self.slave = -1

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False

    def _faulty(self) -> bool:
        return self.fault is not None and self.lines_seen > self.fault.after

    def serve(self) -> None:
        """Read command lines from the master side and answer them until stopped."""
        buffer = b""
        babbling = False
        while True:
            timeout = 0.001 if babbling else None
            ready, _, _ = select.select([self.master, self._stop_r], [], [], timeout)
            if self._stop_r in ready:
                return
            if babbling:
                os.write(self.master, b"\xaa~")
            if self.master not in ready:
                continue
            try:
                chunk = os.read(self.master, 256)
            except OSError:  # no slave open any more
                return
            buffer += chunk
            while b"\n" in buffer:
                raw, buffer = buffer.split(b"\n", 1)
                line = raw.decode("ascii", "replace")
                if not line.strip("\r "):
                    continue
                self.lines_seen += 1
                if self._faulty():
                    kind = self.fault.kind
                    if kind == "close":
                        self._close_link()
                        return
                    if kind == "garbage":
                        os.write(self.master, GARBAGE)
                    babbling = babbling or kind == "babble"
                    continue
                reply = self.firmware.handle(line)
                if reply is not None:
                    os.write(self.master, reply.encode("ascii") + b"\r\n")
            if len(buffer) > MAX_LINE + 1:  # like the sketch, keep only enough to know the line is too long
                buffer = buffer[: MAX_LINE + 1]

    def _close_link(self) -> None:
        """Close both ends, like a board that is unplugged: the host's reads and writes fail."""
        for name in ("master", "slave"):
            fd = getattr(self, name)
            if fd >= 0:
                os.close(fd)
                setattr(self, name, -1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m hapticfx_solenoid.emulator",
        description="Emulate the hapticfx solenoid board on a pseudo-terminal (for users without an Arduino).",
    )
    parser.add_argument("--link", help="also make this path a symlink to the pseudo-terminal (an old symlink there is replaced)")
    parser.add_argument("--fault", choices=FAULTS, help="misbehave, for fault tests")
    parser.add_argument("--fault-after", type=int, default=0, metavar="N", help="answer N lines well first")
    parser.add_argument("--max-on-ms", type=int, default=FirmwareLimits.max_on_ms)
    parser.add_argument("--duty-permille", type=int, default=FirmwareLimits.duty_permille)
    parser.add_argument("--window-ms", type=int, default=FirmwareLimits.window_ms)
    args = parser.parse_args(argv)
    if not (1 <= args.max_on_ms <= 65_535 and 0 <= args.duty_permille <= 1000 and 100 <= args.window_ms <= 65_535):
        parser.error("limits: --max-on-ms 1..65535, --duty-permille 0..1000, --window-ms 100..65535")
    if args.link and os.path.lexists(args.link) and not os.path.islink(args.link):
        parser.error(f"--link {args.link} exists and is not a symlink; not replacing it")
    limits = FirmwareLimits(args.max_on_ms, args.duty_permille, args.window_ms)
    fault = Fault(args.fault, args.fault_after) if args.fault else None
    emulator = PtyEmulator(Firmware(limits), fault=fault)
    path = emulator.port
    if args.link:
        tmp = f"{args.link}.tmp{os.getpid()}"
        os.symlink(emulator.port, tmp)
        os.replace(tmp, args.link)
        path = args.link
    with StopSignals() as stop:
        emulator.start()
        print(path, flush=True)
        print(f"solenoid emulator on {emulator.port} (protocol {PROTOCOL_VERSION}); Ctrl-C to stop", file=sys.stderr,
              flush=True)
        try:
            stop.wait()
        finally:
            emulator.stop()
            if args.link and os.path.islink(args.link):
                os.unlink(args.link)
    return 0


if __name__ == "__main__":
    sys.exit(main())
