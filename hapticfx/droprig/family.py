"""An impact family's contact, as its effect describes it: the contact law, the press and the side that is felt.

The ``contact`` model (:mod:`hapticfx.models.contact`) renders a family from a
:class:`Strike`; ``hapticfx data synth`` simulates the same family's drops from
it (a spec's ``family:``, :mod:`hapticfx.droprig.spec`), so an effect and its
simulated dataset share one scene and one felt side. Unlike the drop rig's
falls, a strike starts at the first contact, and the striker is weighed down
only by the hold force that presses it onto the receiver (a held stylus).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import SignalError
from ..objects import ObjectInfo
from .contact import DropScene, material
from .receiver import Receiver
from .state import JY, VX
from .synth import Drop, scene_for

# A render of an effect's contact takes a few thousand right-hand sides (50 ms); this many is about 5 s here, where
# a 10 t block at k = 1e10 on a 0.1 kg receiver took minutes.
MAX_EVALUATIONS = 1_000_000

FELT = ("sensor", "receiver", "striker")


@dataclass(frozen=True)
class Strike:
    """How a family strikes its receiver: Hunt-Crossley ``stiffness`` (N/m^1.5) and ``damping`` (s/m) (None: the
    striker's material's), the striker's ``tilt`` (rad) and ``offset`` (m) at contact, the force ``hold_n`` (N)
    pressing it on, and what is ``felt``: ``sensor`` (the receiver's 3-axis sensor), ``receiver`` (the struck
    body, along the impact) or ``striker`` (the striking body, along its travel)."""

    stiffness: float | None = None
    damping: float | None = None
    tilt: float = 0.0
    offset: float = 0.0
    hold_n: float = 0.0
    felt: str = "sensor"

    def __post_init__(self):
        if self.felt not in FELT:
            raise ValueError(f"felt must be one of {', '.join(FELT)}, got {self.felt!r}")

    def centre(self, info: ObjectInfo, velocity: float) -> Drop:
        """The impact the effect describes at ``velocity`` (a simulated drop varies around it)."""
        mat = material(info.material)
        return Drop(velocity, tilt=self.tilt, offset=self.offset,
                    stiffness=mat.stiffness if self.stiffness is None else self.stiffness,
                    damping=mat.damping if self.damping is None else self.damping)

    def scene(self, info: ObjectInfo, drop: Drop, receiver: Receiver) -> DropScene:
        """The contact scene of ``drop``: from the first contact, pressed on by the hold force alone."""
        # A held striker's "gravity" is the hold force over its mass (1000 N on 1 g: 1e6 m/s^2). From contact it
        # falls no further than into the receiver, less than a dome radius: that, not falling for the whole run,
        # bounds its speed and so its solver's steps.
        return replace(scene_for(info, drop, receiver), gap=0.0, gravity=self.hold_n / info.mass_kg,
                       max_fall=receiver.dome_radius, max_evaluations=MAX_EVALUATIONS)

    def up(self, receiver: Receiver) -> np.ndarray:
        """Up (against the impact's direction of travel) in the axes of :meth:`acceleration`."""
        if self.felt == "sensor":
            return receiver.mount_rotation() @ np.array([0.0, 0.0, 1.0])
        return np.array([0.0, 0.0, -1.0 if self.felt == "striker" else 1.0])

    def acceleration(self, scene: DropScene, states: np.ndarray, rate_hz: float, *, azimuth: float = 0.0) -> np.ndarray:
        """What is felt, ``(N, 3)`` in m/s^2 (no gravity), from ``states`` sampled at ``rate_hz`` from the first
        contact, each sample the average over the interval it ends.

        ``sensor``: the receiver's sensor in its axes; ``receiver``: the struck body where it is held, its third
        axis along the impact (up); ``striker``: the striking body, its third axis along its travel (its
        deceleration in contact is negative), its first the lateral force's share (in the plane of the impact).
        """
        if self.felt == "sensor":
            return scene.helmet.sensor_acceleration(states, rate_hz, azimuth=azimuth)
        if self.felt == "receiver":
            return replace(scene.helmet, mount_tilt_deg=(0.0, 0.0)).sensor_acceleration(states, rate_hz,
                                                                                       azimuth=azimuth)
        out = np.zeros((states.shape[1], 3))
        out[:, 0] = np.diff(states[VX], prepend=states[VX, :1]) * rate_hz
        # the contact force on the striker, from the integrated impulse (a contact shorter than a sample counts)
        out[:, 2] = np.diff(states[JY], prepend=0.0) * rate_hz / scene.block.mass
        return out

    def response(self, info: ObjectInfo, drop: Drop, receiver: Receiver, n: int, rate_hz: float, *, rtol: float,
                 azimuth: float = 0.0, press: np.ndarray | None = None) -> np.ndarray:
        """:meth:`acceleration` of ``drop``, ``n`` samples at ``rate_hz`` from the first contact, less what the
        hold force alone does (``press``: that response, when it is known; else integrated here)."""
        scene = self.scene(info, drop, receiver)
        states = scene.sample(n, rate_hz, rtol=rtol)
        deepest = float(np.max(scene.penetrations(states)))
        if deepest >= receiver.dome_radius:  # the dome's centre inside the object: no contact geometry is left
            raise SignalError(f"at {drop.velocity:g} m/s the {info.mass_kg:g} kg object sinks {deepest * 1e3:.0f} mm "
                              f"into the receiver, past its {receiver.dome_radius * 1e3:.0f} mm dome: beyond what the "
                              "contact model describes; stiffen the contact, lighten the object or lower "
                              "max_velocity_mps")
        out = self.acceleration(scene, states, rate_hz, azimuth=azimuth)
        if self.hold_n > 0.0 and drop.velocity > 0.0:
            if press is None:
                press = self.response(info, replace(drop, velocity=0.0), receiver, n, rate_hz, rtol=rtol,
                                      azimuth=azimuth)
            out = out - press
        return out
