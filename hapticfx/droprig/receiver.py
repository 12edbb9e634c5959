"""The helmet of the drop rig as a few damped modes, and its acceleration at the sensor.

The helmet sits on the floor. Its response to the contact force:

* a vertical bounce of the whole helmet on its support: a Hunt-Crossley contact
  with the floor (compressed statically by the helmet's weight), so the bounce
  stiffens with amplitude and the helmet lifts off and lands again after a
  strong impact;
* a rocking about a pivot on the floor (seen by the sensor as lateral motion);
* a few shell modes, each driven by the contact force times its mode shape
  ``cos(order * phi)`` at the contact angle ``phi`` on the dome.

The sensor is at the crown, inside, on the suspension: it sees the shell modes
only weakly (small participation). Masses and frequencies are chosen (not
measured) so that the paper's objects at 2.4-5.2 m/s give a few g at the
sensor, the heaviest drops reaching the +-3.6 g range of an ADXL335.
"""

from __future__ import annotations

import math
from functools import lru_cache
from dataclasses import dataclass, field

import numpy as np

from .hertz import G, hunt_crossley
from .state import BE, JT, JY, N_RIGID, VB, VH, YH


@dataclass(frozen=True)
class ShellMode:
    """One shell mode: frequency (Hz), damping ratio, modal mass (kg), shape order and
    participation at the sensor (lateral, vertical) per unit modal acceleration."""

    hz: float
    zeta: float
    mass: float
    order: int
    lateral: float
    vertical: float


@dataclass(frozen=True)
class Helmet:
    """A helmet on the floor: rigid bounce and rocking, shell modes, dome geometry, sensor mount."""

    mass: float = 3.5
    support_hz: float = 22.0
    support_damping: float = 2.0
    rocking_hz: float = 9.0
    rocking_zeta: float = 0.12
    rocking_radius: float = 0.12
    pivot_height: float = 0.16
    dome_radius: float = 0.11
    sensor_height: float = 0.14
    mount_tilt_deg: tuple[float, float] = (7.0, -4.0)
    modes: tuple[ShellMode, ...] = field(default_factory=lambda: (
        ShellMode(118.0, 0.035, 1.6, 1, 0.03, 0.07),
        ShellMode(243.0, 0.03, 2.8, 2, 0.05, 0.05),
        ShellMode(395.0, 0.025, 4.5, 3, 0.03, 0.04),
    ))

    @property
    def support_w(self) -> float:
        return 2 * math.pi * self.support_hz

    @property
    def support_preload(self) -> float:
        """Static compression of the support (m): small-amplitude bounce at ``support_hz``."""
        return 1.5 * G / self.support_w**2

    @property
    def support_k(self) -> float:
        return self.mass * G / self.support_preload**1.5

    def support_force(self, yh, vh):
        """Upward floor force (N) for crown displacement ``yh`` (m, up) and velocity ``vh``."""
        return hunt_crossley(self.support_preload - np.asarray(yh), -np.asarray(vh),
                             stiffness=self.support_k, damping=self.support_damping)

    @property
    def rocking_inertia(self) -> float:
        return self.mass * self.rocking_radius**2

    @property
    def rocking_k(self) -> float:
        return self.rocking_inertia * (2 * math.pi * self.rocking_hz) ** 2

    @property
    def rocking_c(self) -> float:
        return 2 * self.rocking_zeta * self.rocking_inertia * 2 * math.pi * self.rocking_hz

    def mount_rotation(self) -> np.ndarray:
        """Rotation from the helmet frame (x, y lateral; z up) to the sensor's axes."""
        ax, ay = (math.radians(d) for d in self.mount_tilt_deg)
        rx = np.array([[1, 0, 0], [0, math.cos(ax), -math.sin(ax)], [0, math.sin(ax), math.cos(ax)]])
        ry = np.array([[math.cos(ay), 0, math.sin(ay)], [0, 1, 0], [-math.sin(ay), 0, math.cos(ay)]])
        return ry @ rx

    def sensor_acceleration(self, states: np.ndarray, rate_hz: float, *, azimuth: float = 0.0) -> np.ndarray:
        """Acceleration (m/s^2, no gravity) at the sensor in the sensor's axes, ``(N, 3)``.

        ``states`` ``(n_state, N)`` on a uniform grid at ``rate_hz`` starting at the
        release (rest). Contact forces enter as impulses per sample (differences of
        the integrated impulses), so a contact shorter than a sample still counts.
        """
        from scipy.signal import lfilter

        dt = 1.0 / rate_hz
        # force averaged over each sample interval, aligned with the interval's end
        force = np.diff(states[JY:], axis=1, prepend=states[JY:, :1]) / dt
        vertical = (self.support_force(states[YH], states[VH]) + force[0]) / self.mass - G
        beta_dd = (-self.rocking_k * states[BE] - self.rocking_c * states[VB] + force[JT - JY]) / self.rocking_inertia
        lateral = -self.sensor_height * beta_dd
        for i, mode in enumerate(self.modes):
            num, den = _mode_filter(mode, dt)
            acc = lfilter(num, den, force[N_RIGID - JY + i])
            lateral = lateral + mode.lateral * acc
            vertical = vertical + mode.vertical * acc
        helmet_frame = np.stack([lateral * math.cos(azimuth), lateral * math.sin(azimuth), vertical], axis=-1)
        return helmet_frame @ self.mount_rotation().T


@lru_cache(maxsize=64)
def _mode_filter(mode: ShellMode, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital filter from force (held over each sample) to modal acceleration: exact (ZOH)."""
    from scipy.signal import cont2discrete, ss2tf

    w = 2 * math.pi * mode.hz
    a = np.array([[0.0, 1.0], [-w * w, -2 * mode.zeta * w]])
    b = np.array([[0.0], [1.0 / mode.mass]])
    c = np.array([[-w * w, -2 * mode.zeta * w]])
    d = np.array([[1.0 / mode.mass]])
    ad, bd, cd, dd, _ = cont2discrete((a, b, c, d), dt, method="zoh")
    num, den = ss2tf(ad, bd, cd, dd)
    return num[0], den
