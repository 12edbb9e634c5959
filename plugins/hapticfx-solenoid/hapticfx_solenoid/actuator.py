"""The ``solenoid`` actuator: a push-pull solenoid (JF-0826B, 12 V) behind an Arduino.

The solenoid cannot play a waveform (paper Sect. 3.2): each rendered impact
becomes one pulse. The amplitude (for the kinetic-energy model, KE/KE_max of
paper Eq. 10) sets the PWM duty; the time the signal spends above
``threshold`` x its peak (Eq. 11's pulse length b) sets the width. The host
keeps its own on-time and duty-cycle book (refusing or shortening pulses, and
counting each case) and the sketch enforces its limits again on the board.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np

from hapticfx.errors import DeviceError, DeviceUnavailable
from hapticfx.interfaces import Actuator, ActuatorSpec, SafetyLimits
from hapticfx.signal import Signal, valid_number

from .protocol import (
    DEFAULT_BAUD, DUTY_SLOTS, PULSE_GAP_MS, THERMAL_CODES, DutyWindow, FirmwareRefused, fire_command, parse_fire_reply,
    parse_status,
)

if TYPE_CHECKING:
    from .emulator import PtyEmulator
    from .link import SerialLink

EMULATOR_PORT = "emulator"


@dataclass(frozen=True)
class Pulse:
    """One solenoid pulse: width in ms and PWM duty (0..255)."""

    on_ms: int
    duty: int


@dataclass
class SolenoidReport:
    """What happened to the impacts given to one solenoid actuator since it opened."""

    fired: int = 0
    silent: int = 0
    shortened_on_time: int = 0
    shortened_duty: int = 0
    refused_duty: int = 0
    refused_busy: int = 0
    refused_on_time: int = 0
    refused_by_board: int = 0


class SolenoidActuator(Actuator):
    """Push-pull solenoid through an Arduino running ``firmware/solenoid/solenoid.ino``."""

    name = "solenoid"
    spec = ActuatorSpec(
        rate_hz=1000.0,
        volts_peak=12.0,
        band_hz=(0.0, 500.0),
        waveform=False,
        # RMS does not heat a pulsed coil the way on-time does; on-time and duty are the limits that matter.
        limits=SafetyLimits(peak=1.0, rms=1.0, max_on_s=0.1, max_duty=0.25, duty_window_s=10.0),
    )

    @dataclass(frozen=True)
    class Params:
        """Options of the ``solenoid`` actuator (keys of an effect's ``actuator:`` section)."""

        port: str | None = field(default=None, metadata={
            "doc": "serial port (/dev/ttyACM0, COM3), a pyserial URL, or 'emulator' for the built-in "
                   "emulator; the effect's device or --device overrides it"})
        baud: int = field(default=DEFAULT_BAUD, metadata={"min": 1200, "max": 2_000_000, "doc": "baud rate"})
        timeout_s: float = field(default=0.5, metadata={
            "min": 0.01, "max": 1.0, "doc": "longest wait for one reply line before a DeviceError"})
        reset_wait_s: float = field(default=0.0, metadata={
            "min": 0.0, "max": 5.0, "doc": "wait after opening for a board that resets on open (Uno: 2.0)"})
        encoding: Literal["pwm", "width"] = field(default="pwm", metadata={
            "doc": "pwm: amplitude sets the PWM duty; width: full power, amplitude scales the width"})
        width_ms: float | None = field(default=None, metadata={
            "min": 1.0, "max": 1000.0, "doc": "fixed pulse width; default: the time the signal is above threshold"})
        threshold: float = field(default=0.5, metadata={
            "min": 0.01, "max": 1.0, "doc": "fraction of the signal's peak that counts as 'on'"})
        min_duty: float = field(default=0.3, metadata={
            "min": 0.0, "max": 1.0, "doc": "PWM duty of the weakest pulse (a plunger needs some force to move)"})
        silence: float = field(default=0.01, metadata={
            "min": 0.0, "max": 1.0, "doc": "signals with a smaller peak (of full scale) fire no pulse"})
        min_pulse_ms: int = field(default=2, metadata={
            "min": 1, "max": 50, "doc": "shorter pulses (after the limits) are refused, not fired"})

    def __init__(self, params: Params | None = None, context=None):
        self.params = params or self.Params()
        p = self.params
        for name, lo, hi in (("timeout_s", 0.01, 1.0), ("reset_wait_s", 0.0, 5.0), ("threshold", 0.01, 1.0),
                             ("min_duty", 0.0, 1.0), ("silence", 0.0, 1.0), ("min_pulse_ms", 1, 50)):
            valid_number(getattr(p, name), name=f"solenoid {name}", minimum=lo, maximum=hi)
        if p.width_ms is not None:
            valid_number(p.width_ms, name="solenoid width_ms", minimum=1.0, maximum=1000.0)
        if p.encoding not in ("pwm", "width"):
            raise DeviceError(f"solenoid encoding must be 'pwm' or 'width', got {p.encoding!r}")
        device = getattr(context, "device", None)
        self.port = str(device) if device is not None else p.port
        self.limits = self.spec.limits
        self.report = SolenoidReport()
        self.firmware_id: str | None = None
        self.firmware_status: dict[str, int] | None = None
        self.last_pulse: Pulse | None = None
        self._link: SerialLink | None = None
        self._emulator: PtyEmulator | None = None
        self._window: DutyWindow | None = None
        self._max_on_ms = 0
        self._on_until_ms = 0
        self._run_from_ms = 0  # when the coil's current run of pulses began (see _fire)
        self._lock = threading.Lock()  # one command on the line at a time, whoever calls play()
        self._answering = True  # false once a command failed: close() then does not wait for a reply

    # --- device --------------------------------------------------------------------

    def open(self) -> None:
        """Open the port, handshake (PING -> PONG), read the board's limits; DeviceError within 1 s if not."""
        from .link import SerialLink

        if self._link is not None:
            return
        if not self.port:
            raise DeviceUnavailable("solenoid has no serial port: set the effect's actuator.port or device, "
                              "or pass --device (e.g. /dev/ttyACM0, or 'emulator')")
        port = self.port
        if port == EMULATOR_PORT:
            from .emulator import PtyEmulator

            self._emulator = PtyEmulator().start()
            port = self._emulator.port
        p = self.params
        reset_wait_s = 0.0 if self._emulator else p.reset_wait_s  # the emulator does not reboot on open
        link = SerialLink(port, baud=p.baud, timeout_s=p.timeout_s, reset_wait_s=reset_wait_s)
        try:
            _, self.firmware_id = link.open()
            self.firmware_status = parse_status(link.request("STATUS"), source=port)
        except DeviceError:
            link.close()
            self._stop_emulator()
            raise
        self._link = link
        self._arm(self.firmware_status)

    def _arm(self, board: dict[str, int]) -> None:
        """Host limits for this session: the stricter of the effect's limits and the board's."""
        lim = self.limits
        window_ms = max(int(round(lim.duty_window_s * 1000)), DUTY_SLOTS)
        budget_ms = int(lim.max_duty * window_ms) if lim.max_duty is not None else window_ms
        self._max_on_ms = min(int(lim.max_on_s * 1000) if lim.max_on_s is not None else 65_535, board["max_on_ms"])
        if board["window_ms"] * budget_ms > board["budget_ms"] * window_ms:  # board allows a lower duty cycle
            window_ms, budget_ms = board["window_ms"], board["budget_ms"]
        self._window = DutyWindow(budget_ms, window_ms)
        self._on_until_ms = self._run_from_ms = 0
        self.report = SolenoidReport()

    def close(self) -> None:
        """Switch the coil off (best effort) and release the port; never raises."""
        with self._lock:
            self._close()

    def _close(self) -> None:
        if self._link is not None:
            if self._answering:
                try:
                    self._link.request("STOP")
                except DeviceError:
                    pass  # the port is gone or the board is confused; closing must still succeed
            else:  # it stopped answering: STOP goes out all the same, without waiting for a reply
                self._link.send("STOP")
            self._link.close()
            self._link = None
        self._stop_emulator()

    def _stop_emulator(self) -> None:
        if self._emulator is not None:
            self._emulator.stop()
            self._emulator = None

    def describe(self) -> str:
        text = f"solenoid on {self.port or 'no port'}" + (f" ({self.firmware_id})" if self.firmware_id else "")
        if self.last_pulse is not None:
            text += f"; last pulse {self.last_pulse.on_ms} ms at PWM {self.last_pulse.duty}/255"
        return text

    # --- playing -----------------------------------------------------------------------

    def pulse_for(self, signal: Signal) -> Pulse | None:
        """The pulse that renders ``signal`` (None: too quiet to fire), before the thermal limits."""
        if not isinstance(signal, Signal):
            signal = Signal(signal, self.spec.rate_hz)
        p = self.params
        envelope = np.abs(signal.samples)
        if envelope.ndim == 2:  # a solenoid has one coil: strongest channel at each instant
            envelope = envelope.max(axis=0)
        amplitude = min(float(envelope.max()), 1.0)
        if amplitude <= p.silence:
            return None
        if p.encoding == "width":
            base_ms = p.width_ms if p.width_ms is not None else self.limits.max_on_s * 1000 if self.limits.max_on_s else 100.0
            return Pulse(max(1, round(amplitude * base_ms)), 255)
        if p.width_ms is not None:
            on_ms = round(p.width_ms)
        else:
            above = int(np.count_nonzero(envelope >= p.threshold * amplitude))
            on_ms = max(1, round(above / signal.rate_hz * 1000))
        return Pulse(on_ms, round(255 * (p.min_duty + (1 - p.min_duty) * amplitude)))

    def play(self, signal: Signal) -> None:
        """Fire one pulse for ``signal`` unless the thermal limits refuse it (see :attr:`report`)."""
        pulse = self.pulse_for(signal)
        with self._lock:
            if self._link is None:
                raise DeviceError("solenoid: play() before open()", source=self.port)
            try:
                self._fire(pulse)
            except DeviceError:
                self._answering = False
                raise
            self._answering = True

    def _fire(self, pulse: Pulse | None) -> None:
        if pulse is None:
            self.report.silent += 1
            return
        now = int(time.monotonic() * 1000)
        if now < self._on_until_ms:
            self.report.refused_busy += 1
            return
        # A pulse that starts less than the limiter's pulse gap after the last one ended continues it (as the
        # limiter counts a pulse): the run, its short gaps counted as on, keeps to the on-time limit. Without
        # this, pulses fired back to back 1 ms apart kept the coil on for seconds.
        if now >= self._on_until_ms + PULSE_GAP_MS:
            self._run_from_ms = now
        max_on_ms = self._max_on_ms - (now - self._run_from_ms)
        if max_on_ms < self.params.min_pulse_ms:
            self.report.refused_on_time += 1
            return
        on_ms = pulse.on_ms
        if on_ms > max_on_ms:
            on_ms = max_on_ms
            self.report.shortened_on_time += 1
        available = self._window.available_ms(now)
        if on_ms > available:
            if available < self.params.min_pulse_ms:
                self.report.refused_duty += 1
                return
            on_ms = available
            self.report.shortened_duty += 1
        if on_ms < self.params.min_pulse_ms:
            self.report.silent += 1
            return
        try:
            fired_ms, duty = parse_fire_reply(self._link.request(fire_command(on_ms, pulse.duty)), source=self.port)
        except FirmwareRefused as refusal:
            if refusal.code not in THERMAL_CODES:
                raise
            self.report.refused_by_board += 1
            return
        self._window.book(now, fired_ms)
        # The board started the pulse when FIRE arrived, after `now`; +1 covers the two clocks' ms rounding.
        self._on_until_ms = int(time.monotonic() * 1000) + fired_ms + 1
        self.report.fired += 1
        self.last_pulse = Pulse(fired_ms, duty)
