"""Hunt-Crossley contact between a falling rigid block and a helmet shell (planar).

The falling object is a rectangle (half-width ``a`` in the plane of the drop,
half-thickness ``b``) with position, tilt and their rates; the helmet top is a
circular dome of radius ``R`` whose crown can bounce vertically on its support
and rock about a pivot on the floor (see :mod:`hapticfx.droprig.receiver`). The
contact force follows Hunt and Crossley (1975)::

    F = k * delta**1.5 * (1 + alpha * d(delta)/dt),   F >= 0

along the dome normal through the point of the block closest to the dome
centre, so flat landings, edge hits, rocking on the dome, rebounds and
secondary impacts all come from one law. The state also carries running
integrals of the contact force (vertical impulse, torque impulse about the
pivot, and the impulse seen by each shell mode) so that the helmet response
can be sampled on any grid without missing a contact shorter than a sample.

Integration uses :func:`scipy.integrate.solve_ivp`; ``LSODA`` (which switches
to BDF when the problem turns stiff, as in sustained contact) is the default.
``hapticfx bench contact`` measures the choice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SignalError
from ..signal import valid_number
from .receiver import Receiver
from .hertz import G
from .state import BE, JT, JY, N_RIGID, OM, TH, VB, VH, VX, VY, X, Y, YH


@dataclass(frozen=True)
class Material:
    """Hunt-Crossley parameters of an object material against the helmet shell.

    ``stiffness`` k in N/m^1.5 and ``damping`` alpha in s/m. The values lump
    the local compliance of the shell with that of the object; they are chosen
    to give contact times of a few ms and restitution coefficients typical of
    each material on a hard plastic shell (not measured).
    """

    name: str
    stiffness: float
    damping: float


MATERIALS: dict[str, Material] = {
    m.name: m
    for m in (
        Material("plastic", 1.5e6, 0.30),
        Material("concrete", 8.0e6, 0.38),
        Material("wood", 3.0e6, 0.26),
        Material("steel", 2.0e7, 0.12),
        Material("ceramic", 1.2e7, 0.20),
        Material("rubber", 4.0e5, 0.60),
        Material("aluminium", 1.5e7, 0.15),
        Material("glass", 2.5e7, 0.10),
        Material("unknown", 3.0e6, 0.26),
    )
}


def material(name: str) -> Material:
    """The material table entry for ``name`` (``unknown`` for a material not in the table)."""
    return MATERIALS.get(name, MATERIALS["unknown"])


@dataclass(frozen=True)
class Block:
    """The falling object as a planar rigid rectangle: mass (kg), half extents (m)."""

    mass: float
    half_width: float
    half_thickness: float

    @property
    def inertia(self) -> float:
        return self.mass * (self.half_width**2 + self.half_thickness**2) / 3.0

    @classmethod
    def from_dimensions(cls, mass_kg: float, dimensions_mm) -> "Block":
        """A block landing on its largest face: thinnest dimension vertical, longest in the drop plane."""
        dims = [float(d) for d in dimensions_mm if float(d) > 0]
        if not dims:
            # no size given: a 5 cm cube of the object's mass
            dims = [50.0]
        return cls(mass_kg, max(dims) / 2000.0, min(dims) / 2000.0)


@dataclass
class DropScene:
    """One drop: block, material law, helmet and the initial pose and speed.

    ``tilt`` (rad) is the block's angle at release, ``offset`` (m) its lateral
    distance from the crown, ``spin`` (rad/s) its angular rate at contact,
    ``gap`` (m) its clearance above the dome at release (negative: pressed in),
    ``gravity`` (m/s^2) the acceleration of gravity on the block (the helmet
    always rests on its support under its own weight), ``max_fall`` (m) the furthest the block can fall below
    where it starts: with :attr:`gravity` it bounds the block's speed, and so the solver's steps, by energy
    (inf: by falling for the whole run). ``max_evaluations`` (None: no limit): the right-hand sides the solvers
    may call before the integration is given up with a :class:`SignalError` (a render that would take minutes).
    """

    block: Block
    helmet: Receiver
    stiffness: float
    damping: float
    velocity: float
    tilt: float = 0.0
    offset: float = 0.0
    spin: float = 0.0
    gap: float = 2e-4
    gravity: float = G
    max_fall: float = math.inf
    max_evaluations: int | None = None

    def __post_init__(self):
        valid_number(self.block.mass, name="mass_kg", minimum=1e-6, maximum=1e4)
        valid_number(self.stiffness, name="stiffness", minimum=1.0, maximum=1e14)
        valid_number(self.damping, name="damping", minimum=0.0, maximum=100.0)
        valid_number(self.velocity, name="velocity", minimum=0.0, maximum=1000.0)
        if self.block.half_width <= 0 or self.block.half_thickness <= 0:
            raise SignalError("block half extents must be > 0")
        h = self.helmet
        self._shapes = tuple(m.order for m in h.modes)
        self._preload, self._support_damping = h.support_preload, h.support_damping
        self._rocking_k, self._rocking_c, self._rocking_inertia = h.rocking_k, h.rocking_c, h.rocking_inertia
        self.n_state = N_RIGID + len(h.modes)
        self.evaluations = 0  # right-hand side calls, including those made for Jacobians
        self._jac_scale = self.scales()[:JY]

    # --- geometry -------------------------------------------------------------
    def dome_centre(self, yh: float, beta: float) -> tuple[float, float]:
        h = self.helmet
        arm = h.pivot_height - h.dome_radius
        return -arm * math.sin(beta), yh - h.pivot_height + arm * math.cos(beta)

    def closest(self, s) -> tuple[float, float, float, float, float]:
        """Penetration, contact point (world) and unit normal (dome centre towards block)."""
        x, y, th = float(s[X]), float(s[Y]), float(s[TH])
        return self._closest(x, y, th, *self.dome_centre(float(s[YH]), float(s[BE])))

    def _closest(self, x, y, th, cx, cy):
        a, b = self.block.half_width, self.block.half_thickness
        c, sn = math.cos(th), math.sin(th)
        dx, dy = cx - x, cy - y
        bx, by = c * dx + sn * dy, -sn * dx + c * dy  # dome centre in the block frame
        qx, qy = min(max(bx, -a), a), min(max(by, -b), b)
        ex, ey = qx - bx, qy - by
        dist = math.hypot(ex, ey)
        if dist > 1e-12 * (a + b):
            nbx, nby = ex / dist, ey / dist
        else:  # dome centre inside the block (only under absurd penetration): push out of the nearest face
            if a - abs(bx) < b - abs(by):
                qx, qy, nbx, nby = math.copysign(a, bx), by, -math.copysign(1.0, bx), 0.0
                dist = -(a - abs(bx))
            else:
                qx, qy, nbx, nby = bx, math.copysign(b, by), 0.0, -math.copysign(1.0, by)
                dist = -(b - abs(by))
        delta = self.helmet.dome_radius - dist
        px, py = x + c * qx - sn * qy, y + sn * qx + c * qy
        nx, ny = c * nbx - sn * nby, sn * nbx + c * nby
        return delta, px, py, nx, ny

    def penetrations(self, states: np.ndarray) -> np.ndarray:
        """:meth:`closest`'s penetration at each of ``states`` ``(n_state, n)``, vectorised."""
        h, a, b = self.helmet, self.block.half_width, self.block.half_thickness
        arm = h.pivot_height - h.dome_radius
        cx, cy = -arm * np.sin(states[BE]), states[YH] - h.pivot_height + arm * np.cos(states[BE])
        c, sn = np.cos(states[TH]), np.sin(states[TH])
        dx, dy = cx - states[X], cy - states[Y]
        bx, by = c * dx + sn * dy, -sn * dx + c * dy
        dist = np.hypot(np.clip(bx, -a, a) - bx, np.clip(by, -b, b) - by)
        inside = dist <= 1e-12 * (a + b)
        dist = np.where(inside, -np.minimum(a - np.abs(bx), b - np.abs(by)), dist)
        return h.dome_radius - dist

    def initial_state(self) -> np.ndarray:
        """The block at rest pose ``tilt``/``offset``, ``gap`` above the dome, falling at ``velocity``."""
        s = np.zeros(self.n_state)
        s[X], s[TH] = self.offset, self.tilt
        s[VY], s[OM] = -self.velocity, self.spin
        lo, hi = -1.0, 1.0
        for _ in range(80):  # bisection on height: penetration is monotone in Y
            s[Y] = 0.5 * (lo + hi)
            if -self.closest(s)[0] > self.gap:
                hi = s[Y]
            else:
                lo = s[Y]
        s[Y] = hi
        return s

    # --- dynamics ---------------------------------------------------------------
    def rhs(self, t, s):
        """Time derivative of the state (see the module docstring)."""
        return np.array(self.derivative()(t, s))

    def derivative(self):
        """The right-hand side ``f(t, s)`` as the solvers call it, returning a list of floats.

        The same arithmetic as :meth:`rhs`, in the same order (the same bits), with the scene's constants
        bound once: the solvers call it thousands of times per impact, and attribute look-ups, method calls
        and a numpy array per call were most of its cost. Each call counts in ``evaluations``.
        """
        h, scene = self.helmet, self
        a, b, radius = self.block.half_width, self.block.half_thickness, h.dome_radius
        tiny = 1e-12 * (a + b)
        m, inertia, pivot = self.block.mass, self.block.inertia, h.pivot_height
        arm = h.pivot_height - h.dome_radius
        neg_arm = -arm
        k, alpha, gravity = self.stiffness, self.damping, self.gravity
        lift, mass_h = self._lift, h.mass
        neg_rocking_k, rocking_c, rocking_inertia = -self._rocking_k, self._rocking_c, self._rocking_inertia
        shapes = self._shapes
        silent = [0.0] * len(shapes)
        closest = self._closest
        sqrt, sin, cos, hypot, atan2 = math.sqrt, math.sin, math.cos, math.hypot, math.atan2
        cap = math.inf if self.max_evaluations is None else self.max_evaluations

        def f(t, s):
            scene.evaluations += 1
            if scene.evaluations > cap:  # raised through the solver: it stops at once
                raise SignalError(f"the contact needed more than {cap:,} solver steps (a {m:g} kg object at "
                                  f"{scene.velocity:g} m/s on k = {k:g}): too stiff or heavy a contact to integrate "
                                  "in time; soften it, lighten the object or lower the velocity")
            x, y, th, vx, vy, om, yh, vh, be, vb = s[:JY].tolist()
            # the dome centre (DropScene.dome_centre) and the point of the block closest to it (DropScene._closest)
            cx, cy = neg_arm * sin(be), yh - pivot + arm * cos(be)
            c, sn = cos(th), sin(th)
            dx, dy = cx - x, cy - y
            bx, by = c * dx + sn * dy, -sn * dx + c * dy
            qx = a if bx > a else (-a if bx < -a else bx)
            qy = b if by > b else (-b if by < -b else by)
            ex, ey = qx - bx, qy - by
            dist = hypot(ex, ey)
            if dist > tiny:
                delta = radius - dist
                px, py = x + c * qx - sn * qy, y + sn * qx + c * qy
            else:
                delta, px, py, nx, ny = closest(x, y, th, cx, cy)
            force = 0.0
            if delta > 0.0:
                if dist > tiny:
                    nbx, nby = ex / dist, ey / dist
                    nx, ny = c * nbx - sn * nby, sn * nbx + c * nby
                rx, ry = px - x, py - y
                rate = -((vx - om * ry + vb * (py + pivot)) * nx + (vy + om * rx - vh - vb * px) * ny)
                force = k * delta * sqrt(delta) * (1.0 + alpha * rate)
            up = lift(yh, vh)
            if force > 0.0:
                fx, fy = force * nx, force * ny
                torque = -(px * fy - (py + pivot) * fx)  # reaction on the helmet about the pivot
                out = [
                    vx, vy, om, fx / m, fy / m - gravity, ((px - x) * fy - (py - y) * fx) / inertia,
                    vh, up - fy / mass_h,
                    vb, (neg_rocking_k * be - rocking_c * vb + torque) / rocking_inertia,
                    -fy, torque,
                ]
                if shapes:
                    phi = atan2(px - cx, py - cy)
                    out += [force * cos(order * phi) for order in shapes]
                return out
            # apart (or a contact that would pull): no contact force
            return [vx, vy, om, 0.0, -gravity, 0.0, vh, up,
                    vb, (neg_rocking_k * be - rocking_c * vb) / rocking_inertia, 0.0, 0.0, *silent]

        return f

    def _lift(self, yh: float, vh: float) -> float:
        """The support's push on the receiver less the receiver's weight, per unit of its mass (m/s^2), at crown
        displacement ``yh`` and velocity ``vh``.

        The push is ``M g (c / c0)^1.5 (1 - alpha vh)`` at compression ``c = c0 - yh`` (``c0``: the preload),
        never pulling. ``(c / c0)^1.5 - 1`` is ``expm1(1.5 log1p(-yh / c0))``: written as push minus weight it
        cancels to the rounding of ``M g``, and a displacement below ``c0``'s last bit (a 1 mg object's
        impact) is lost in that noise, which the solver then chases with ever smaller steps.
        """
        damped = 1.0 - self._support_damping * vh
        if yh >= self._preload or damped <= 0.0:
            return -G
        return G * (math.expm1(1.5 * math.log1p(-yh / self._preload)) * damped - self._support_damping * vh)

    def scales(self) -> np.ndarray:
        """Typical magnitude of each state, for absolute tolerances."""
        # tolerances relative to the impact itself down to 1 mm/s (below, absolute: a 1e-9 m/s touch on k = 1e10 would
        # take minutes), or to what a pressing force does in 1 ms
        v = max(self.velocity, 1e-3, self.gravity * 1e-3)
        imp = self.block.mass * v
        sc = np.empty(self.n_state)
        sc[[X, Y]] = self.block.half_width + self.block.half_thickness
        sc[TH], sc[OM] = 1.0, v / self.block.half_width
        sc[[VX, VY]] = v
        sc[YH], sc[VH] = imp / (self.helmet.mass * self.helmet.support_w), imp / self.helmet.mass
        sc[BE], sc[VB] = 1e-3, 1e-2
        sc[JY:] = imp
        sc[JT] = imp * self.helmet.pivot_height
        return sc

    def jac(self, t, s) -> np.ndarray:
        """Jacobian by forward differences over the dynamic states.

        The impulse states never feed back, so their columns are zero; scipy's own
        difference Jacobian keeps growing its step for such columns until it
        overflows (seen with Radau at k = 1e10), hence this one with fixed steps.
        """
        return self.jacobian(self.derivative())(t, s)

    def jacobian(self, fn):
        """:meth:`jac` as a function ``(t, s)`` of the right-hand side ``fn`` (from :meth:`derivative`)."""
        n, scale = self.n_state, self._jac_scale

        def jac(t, s):
            f0 = np.array(fn(t, s))
            out = np.zeros((n, n))
            steps = 1.5e-8 * np.maximum(np.abs(s[:JY]), scale)
            for i in range(JY):
                shifted = s.copy()
                shifted[i] += steps[i]
                out[:, i] = (np.array(fn(t, shifted)) - f0) / steps[i]
            return out

        return jac

    def _tolerances(self, duration: float, rtol: float) -> tuple[np.ndarray, float]:
        """Absolute tolerances and the largest step for a run of ``duration`` s."""
        # atol below rtol * scale: accuracy is relative for large states and absolute near zero
        atol = rtol * 1e-2 * self.scales()
        # Free fall is a polynomial the error estimators see as exact, so without a bound a solver
        # can step clean through the helmet; no step may move the block by more than half the dome radius.
        speed = self.velocity + self.gravity * duration
        if math.isfinite(self.max_fall):
            speed = min(speed, math.sqrt(self.velocity ** 2 + 2.0 * self.gravity * self.max_fall))
        max_step = min(duration, 0.5 * self.helmet.dome_radius / speed) if speed > 0 else duration
        return atol, max_step

    def integrate(self, duration: float, *, method: str = "LSODA", rtol: float = 1e-7, dense: bool = True):
        """Integrate from release for ``duration`` s; returns scipy's ``OdeResult``."""
        from scipy.integrate import solve_ivp

        atol, max_step = self._tolerances(duration, rtol)
        fn = self.derivative()
        implicit = {"jac": self.jacobian(fn)} if method in ("Radau", "BDF", "LSODA") else {}
        sol = solve_ivp(fn, (0.0, duration), self.initial_state(), method=method, rtol=rtol, atol=atol,
                        dense_output=dense, max_step=max_step, **implicit)
        if not sol.success:
            raise SignalError(f"contact integration failed ({method}): {sol.message}")
        return sol

    def sample(self, n: int, rate_hz: float, *, rtol: float = 1e-7) -> np.ndarray:
        """The state ``(n_state, n)`` at ``n`` instants ``rate_hz`` apart from the release.

        The same LSODA as :meth:`integrate`, through ``scipy.integrate.odeint``,
        which interpolates onto the grid in compiled code: about three times
        faster than a dense ``solve_ivp`` solution evaluated on a fine grid.
        """
        from scipy.integrate import odeint

        t = np.arange(n) / float(rate_hz)
        duration = max(float(t[-1]), 1.0 / float(rate_hz))
        atol, max_step = self._tolerances(duration, rtol)
        fn = self.derivative()
        states, info = odeint(fn, self.initial_state(), t, Dfun=self.jacobian(fn), tfirst=True, rtol=rtol,
                              atol=atol, hmax=max_step, mxstep=200_000, full_output=True)
        if info["message"] != "Integration successful.":
            raise SignalError(f"contact integration failed (LSODA): {info['message']}")
        return states.T
