"""The host end of the serial line: one command out, one reply line back, within a deadline.

Every pyserial failure (port absent, closed under us, reply missing, garbage)
becomes a one-line :class:`hapticfx.errors.DeviceError` naming the port.
"""

from __future__ import annotations

import os
import time

from hapticfx.errors import DeviceError, DeviceUnavailable

from .protocol import DEFAULT_BAUD, MAX_LINE, decode_line, parse_pong


def _port_failures() -> tuple[type[BaseException], ...]:
    """What pyserial raises when the port fails under it (termios.error is no OSError)."""
    import serial

    try:
        import termios
    except ImportError:  # Windows
        return (serial.SerialException, OSError)
    return (serial.SerialException, OSError, termios.error)


class SerialLink:
    """A line-oriented connection to the board (or the emulator) through pyserial."""

    def __init__(self, port: str, *, baud: int = DEFAULT_BAUD, timeout_s: float = 0.5, reset_wait_s: float = 0.0):
        self.port = port
        self.baud = baud
        self.timeout_s = timeout_s
        self.reset_wait_s = reset_wait_s
        self._serial = None

    @property
    def is_open(self) -> bool:
        return self._serial is not None

    def open(self) -> tuple[int, str]:
        """Open the port and do the handshake; returns (protocol version, firmware id)."""
        import serial  # pyserial: imported only when a device is really used

        try:
            self._serial = serial.serial_for_url(
                self.port, baudrate=self.baud, timeout=self.timeout_s, write_timeout=self.timeout_s
            )
            if self.reset_wait_s:
                time.sleep(self.reset_wait_s)  # a board that resets when the port opens boots first
            self._serial.reset_input_buffer()
        except (*_port_failures(), ValueError) as exc:
            self.close()
            absent = "://" not in self.port and not os.path.exists(self.port)
            raise (DeviceUnavailable if absent else DeviceError)(f"cannot open serial port: {exc}",
                                                                 source=self.port) from None
        try:
            # The leading newline ends whatever half line the board may hold; it ignores empty lines.
            return parse_pong(self.request("\nPING", what="PING"), source=self.port)
        except DeviceError:
            self.close()
            raise

    def request(self, command: str, *, what: str | None = None) -> str:
        """Send one command line and return its reply line (without the line ending)."""
        import serial

        if self._serial is None:
            raise DeviceError("serial port is not open", source=self.port)
        what = what or command.split()[0]
        try:
            self._serial.write(command.encode("ascii") + b"\n")
            self._serial.flush()
            raw = self._read_line()
        except serial.SerialTimeoutException:
            raise DeviceError(f"the board did not take {what} within {self.timeout_s:g} s", source=self.port) from None
        except _port_failures() as exc:
            raise DeviceError(f"serial port failed during {what} (closed or unplugged?): {exc}", source=self.port) from None
        if not raw:
            raise DeviceError(f"no answer to {what} within {self.timeout_s:g} s (board silent or not running the "
                              "hapticfx sketch?)", source=self.port)
        if not raw.endswith(b"\n"):
            raise DeviceError(f"no complete reply line to {what} within {self.timeout_s:g} s and {MAX_LINE * 4} "
                              f"bytes; got {raw[:40]!r} (not the hapticfx solenoid protocol?)", source=self.port)
        return decode_line(raw, what=what, source=self.port)

    def send(self, command: str) -> None:
        """Send one command line without waiting for its reply (best effort; never raises)."""
        if self._serial is None:
            return
        try:
            self._serial.write(command.encode("ascii") + b"\n")
            self._serial.flush()
        except Exception:  # the port may be gone; there is no one to tell
            pass

    def _read_line(self) -> bytes:
        """Bytes up to and including the newline, or what came before the deadline / length limit."""
        deadline = time.monotonic() + self.timeout_s
        raw = b""
        while not raw.endswith(b"\n") and len(raw) <= MAX_LINE * 4:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            self._serial.timeout = remaining
            chunk = self._serial.read_until(b"\n", size=MAX_LINE * 4 + 1 - len(raw))
            if not chunk:
                break
            raw += chunk
        return raw

    def close(self) -> None:
        """Close the port; never raises (the port may already be gone)."""
        if self._serial is None:
            return
        try:
            self._serial.close()
        except Exception:  # closing a port that vanished must not break the caller's cleanup
            pass
        self._serial = None
