"""The solenoid line protocol, version 1: constants, the on-time book-keeping
the firmware and the host share, and the parsers for the board's replies.

Pure Python (no pyserial): the emulator, the host actuator and the tests all
use it, and ``firmware/solenoid/solenoid.ino`` implements the same rules in C++.
The protocol is documented in ``docs/solenoid.md``; in short, one ASCII line
per command (``\\n``-terminated, ``\\r`` ignored, at most ``MAX_LINE`` bytes)
and exactly one reply line per non-empty command::

    PING                 -> PONG <protocol> <firmware-id>
    STATUS               -> STATUS on=<0|1> used_ms=<n> budget_ms=<n> max_on_ms=<n>
                                   duty_permille=<n> window_ms=<n> fired=<n> refused=<n>
    FIRE <ms> <duty>     -> OK FIRE <ms> <duty>      (duty: PWM 0..255)
    STOP                 -> OK STOP
    anything refused     -> ERR <CODE> <text>        (CODE: SYNTAX RANGE LIMIT BUSY DUTY TOOLONG)
"""

from __future__ import annotations

from dataclasses import dataclass

from hapticfx.errors import DeviceError
from hapticfx.safety import SafetyLimiter

PROTOCOL_VERSION = 1
MAX_LINE = 32
DEFAULT_BAUD = 115200
DUTY_SLOTS = 10
# A pulse that starts less than this after the last one ended continues it (the sketch's PULSE_GAP_MS; the
# core limiter's pulse_gap_s): a run of such pulses, its gaps counted as on, keeps to the on-time limit.
PULSE_GAP_MS = round(SafetyLimiter.pulse_gap_s * 1000)
ERROR_CODES = ("SYNTAX", "RANGE", "LIMIT", "BUSY", "DUTY", "TOOLONG")
STATUS_KEYS = ("on", "used_ms", "budget_ms", "max_on_ms", "duty_permille", "window_ms", "fired", "refused")
# What the sketch can report (16-bit times, a 32-bit window, counters): a number beyond is a corrupt line.
_MS, _COUNT = (0, 65_535), (0, 2**32 - 1)
STATUS_RANGES = {"on": (0, 1), "used_ms": (0, 2**32 - 1), "budget_ms": (0, 2**32 - 1), "max_on_ms": _MS,
                 "duty_permille": (0, 1000), "window_ms": (1, 2**32 - 1), "fired": _COUNT, "refused": _COUNT}
# Refusals that are about heat, not about a malformed command: the host counts them.
THERMAL_CODES = ("LIMIT", "BUSY", "DUTY")


@dataclass(frozen=True)
class FirmwareLimits:
    """The thermal limits compiled into the sketch (``MAX_ON_MS`` etc.); the emulator uses the same."""

    max_on_ms: int = 100
    duty_permille: int = 250
    window_ms: int = 10_000

    @property
    def budget_ms(self) -> int:
        return self.window_ms * self.duty_permille // 1000


class DutyWindow:
    """On-time spent in a sliding window, kept in ``DUTY_SLOTS + 1`` slots as the sketch keeps it.

    The window of ``window_ms`` is cut into ``DUTY_SLOTS`` slots; a pulse is
    booked in full into the slot where it starts. The on-time "used" is the sum
    over the current slot and the ``DUTY_SLOTS`` before it, so it always covers
    at least the whole window: the duty cycle over any window is never above
    ``budget_ms / window_ms`` (the long-run duty is at most 10/11 of it).
    """

    def __init__(self, budget_ms: int, window_ms: int):
        if window_ms < DUTY_SLOTS or budget_ms < 0:
            raise ValueError(f"bad duty window: budget {budget_ms} ms over {window_ms} ms")
        self.budget_ms = int(budget_ms)
        self.slot_ms = int(window_ms) // DUTY_SLOTS
        self._ring = [0] * (DUTY_SLOTS + 1)
        self._slot = 0

    def _advance(self, now_ms: int) -> None:
        current = int(now_ms) // self.slot_ms
        if current - self._slot > DUTY_SLOTS:
            self._ring = [0] * (DUTY_SLOTS + 1)
            self._slot = current
        while self._slot < current:
            self._slot += 1
            self._ring[self._slot % (DUTY_SLOTS + 1)] = 0

    def used_ms(self, now_ms: int) -> int:
        self._advance(now_ms)
        return sum(self._ring)

    def available_ms(self, now_ms: int) -> int:
        return max(0, self.budget_ms - self.used_ms(now_ms))

    def book(self, now_ms: int, on_ms: int) -> None:
        self._advance(now_ms)
        self._ring[self._slot % (DUTY_SLOTS + 1)] += int(on_ms)


class FirmwareRefused(DeviceError):
    """The board answered ``ERR <code> ...`` to a command."""

    def __init__(self, code: str, text: str, *, source: str | None = None):
        self.code = code
        self.text = text
        super().__init__(f"board refused: ERR {code} {text}".rstrip(), source=source)


def _fail(problem: str, line: bytes | str, source: str | None) -> DeviceError:
    return DeviceError(f"{problem}; the board answered {line[:60]!r} (not the hapticfx solenoid protocol?)",
                       source=source)


def decode_line(raw: bytes, *, what: str = "a command", source: str | None = None) -> str:
    """One reply line as text without its line ending; garbage raises :class:`DeviceError`."""
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError:
        raise _fail(f"reply to {what} is not ASCII", raw, source) from None
    text = text.rstrip("\r\n")
    if not text.isprintable():
        raise _fail(f"reply to {what} has control characters", raw, source)
    return text


def check_refusal(line: str, *, source: str | None = None) -> None:
    """Raise :class:`FirmwareRefused` when ``line`` is a well-formed ``ERR`` reply."""
    parts = line.split(" ", 2)
    if parts[0] == "ERR" and len(parts) >= 2 and parts[1] in ERROR_CODES:
        raise FirmwareRefused(parts[1], parts[2] if len(parts) > 2 else "", source=source)


def parse_pong(line: str, *, source: str | None = None) -> tuple[int, str]:
    """``PONG <protocol> <firmware-id>`` -> (protocol version, firmware id)."""
    parts = line.split()
    if len(parts) != 3 or parts[0] != "PONG" or not parts[1].isdigit():
        raise _fail("expected 'PONG <protocol> <firmware-id>' to PING", line, source)
    version = int(parts[1])
    if version != PROTOCOL_VERSION:
        raise DeviceError(
            f"the board speaks solenoid protocol {version}, this host speaks {PROTOCOL_VERSION}; "
            "upload the sketch that ships with this hapticfx-solenoid version",
            source=source,
        )
    return version, parts[2]


def parse_status(line: str, *, source: str | None = None) -> dict[str, int]:
    """``STATUS k=v ...`` -> dict with every key of :data:`STATUS_KEYS`."""
    parts = line.split()
    if not parts or parts[0] != "STATUS":
        check_refusal(line, source=source)
        raise _fail("expected 'STATUS ...' to STATUS", line, source)
    values: dict[str, int] = {}
    for item in parts[1:]:
        key, sep, value = item.partition("=")
        if not sep or not value.isdigit():
            raise _fail(f"bad STATUS field {item!r}", line, source)
        values[key] = int(value)
    missing = [k for k in STATUS_KEYS if k not in values]
    if missing:
        raise _fail(f"STATUS lacks {', '.join(missing)}", line, source)
    for key, (lo, hi) in STATUS_RANGES.items():
        if not lo <= values[key] <= hi:
            raise _fail(f"STATUS {key}={values[key]} is outside {lo}..{hi}", line, source)
    return values


def parse_fire_reply(line: str, *, source: str | None = None) -> tuple[int, int]:
    """``OK FIRE <ms> <duty>`` -> (ms, duty); ``ERR ...`` raises :class:`FirmwareRefused`."""
    check_refusal(line, source=source)
    parts = line.split()
    if len(parts) != 4 or parts[:2] != ["OK", "FIRE"] or not (parts[2].isdigit() and parts[3].isdigit()):
        raise _fail("expected 'OK FIRE <ms> <duty>' to FIRE", line, source)
    ms, duty = int(parts[2]), int(parts[3])
    if not (1 <= ms <= _MS[1] and 0 <= duty <= 255):
        raise _fail(f"FIRE reply {ms} ms at duty {duty} is outside 1..65535 ms and 0..255", line, source)
    return ms, duty


def fire_command(on_ms: int, duty: int) -> str:
    """The FIRE line for a pulse of ``on_ms`` milliseconds at PWM ``duty`` (0..255)."""
    if not (1 <= on_ms <= 65_535 and 0 <= duty <= 255):
        raise ValueError(f"pulse out of protocol range: {on_ms} ms, duty {duty}")
    return f"FIRE {int(on_ms)} {int(duty)}"
