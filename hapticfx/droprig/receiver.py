"""The struck body (the receiver) as a few damped modes, and its acceleration at the sensor.

One model serves every struck body: the drop rig's helmet, and the receivers of
the impact families (:data:`RECEIVERS`: a tabletop, a bat's handle, a car seat,
a boot). The ``contact`` model and ``hapticfx data synth`` both take a
:class:`Receiver`. It sits on a support (the floor, the legs of a table, the
hands on a bat, a car's suspension). Its response to the contact force:

* a vertical bounce of the whole helmet on its support: a Hunt-Crossley contact
  with the floor (compressed statically by the helmet's weight), so the bounce
  stiffens with amplitude and the helmet lifts off and lands again after a
  strong impact;
* a rocking about a pivot on the floor (seen by the sensor as lateral motion);
* a few shell modes, each driven by the contact force times its mode shape
  ``cos(order * phi)`` at the contact angle ``phi`` on the dome.

For the helmet, the sensor is at the crown, inside, on the suspension: it sees
the shell modes only weakly (small participation). Masses and frequencies are
chosen (not measured) so that the paper's objects at 2.4-5.2 m/s give a few g at
the sensor, the heaviest drops reaching the +-3.6 g range of an ADXL335. The
other receivers' values are chosen too (docs/families.md says from what).
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
class Receiver:
    """A struck body on its support: effective mass, rigid bounce and rocking on the support, modes (frequency,
    damping ratio, modal mass, shape order, participation at the sensor), the struck surface's radius and the
    sensor's mount. The defaults are the drop rig's helmet on the floor."""

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


def _receiver(mass, support_hz, support_damping, dome_radius, modes, **rest) -> Receiver:
    return Receiver(mass=mass, support_hz=support_hz, support_damping=support_damping, dome_radius=dome_radius,
                    modes=tuple(ShellMode(hz, zeta, m, 1, 0.0, vertical) for hz, zeta, m, vertical in modes), **rest)


# The shipped receivers. The helmet is the drop rig's; the others are chosen (not measured) for what each family
# renders: docs/families.md gives the reasoning and the published values each family is checked against.
RECEIVERS: dict[str, Receiver] = {
    "helmet": Receiver(),
    # a wooden tabletop on four legs, struck near its middle: plate modes ringing for a few hundred ms
    "tabletop": _receiver(5.0, 35.0, 1.0, 1.0, ((95.0, 0.02, 2.0, 0.9), (240.0, 0.015, 3.0, 0.5)),
                          rocking_hz=12.0, rocking_zeta=0.05, pivot_height=0.75, sensor_height=0.74),
    # the bat's effective mass at the sweet spot, held in the hands (a soft support), its bending modes
    "bat-handle": _receiver(0.9, 8.0, 3.0, 0.035, ((170.0, 0.03, 3.0, 0.3), (560.0, 0.03, 4.0, 0.15)),
                            rocking_hz=3.0, rocking_zeta=0.3, pivot_height=0.6, sensor_height=0.55),
    # a car body's corner on its suspension, felt in the seat: body and seat modes
    "car-seat": _receiver(100.0, 1.3, 4.0, 0.33, ((4.5, 0.45, 60.0, 1.2), (13.0, 0.12, 40.0, 0.4)),
                          rocking_hz=1.1, rocking_zeta=0.3, pivot_height=0.5, sensor_height=0.5),
    # a foot in a boot, the leg behind it: the sole's and the foot's modes
    # (the struck surface's radius larger than the ball's 10 cm of compression at 40 m/s)
    "boot": _receiver(1.2, 12.0, 2.5, 0.2, ((55.0, 0.2, 0.6, 0.8), (150.0, 0.12, 0.8, 0.4)),
                      rocking_hz=6.0, rocking_zeta=0.3, pivot_height=0.45, sensor_height=0.1),
}


def named_receiver(name: str) -> Receiver:
    """A shipped receiver by name (KeyError names the known ones)."""
    if name not in RECEIVERS:
        raise KeyError(f"unknown receiver {name!r}; shipped: {', '.join(RECEIVERS)}")
    return RECEIVERS[name]
