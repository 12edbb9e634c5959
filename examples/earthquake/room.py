"""The shaking room in MuJoCo: shelves holding the paper's four objects above a head.

The room (floor, walls' shelves, a standing person's torso and head) is one
heavy body on two horizontal slide joints whose position and velocity are
prescribed every step from the ground motion, so the shelves shake and the
objects on them are moved only by contact and friction. Each shelf sags a few
degrees towards the head: friction holds an object while the ground is quiet,
strong shaking breaks it loose and it creeps over the edge and falls.

Head contacts are found every step between ``mj_step1`` (collision detection
on the pre-step state) and ``mj_step2`` (integration), so the relative normal
velocity read from the contact Jacobians is the velocity at first contact,
before the contact impulse acts. Each contact also says where on the head it
landed, in the head frame of docs/protocol.md: metres from the head's centre,
x to the right ear, y forward, z up; the person faces +y, so the head frame's
axes are the room's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hapticfx.objects import PAPER_OBJECTS, ObjectInfo

HEAD_RADIUS = 0.13        # the head in the paper's safety helmet
HEAD_CENTRE_Z = 1.62
HEAD_TOP_Z = HEAD_CENTRE_Z + HEAD_RADIUS

# object id -> (direction of its shelf from the head, drop height above the head top, m)
SHELVES: dict[str, tuple[tuple[float, float], float]] = {
    "plastic-frame": ((1.0, 0.0), 0.45),
    "concrete-brick": ((0.0, 1.0), 0.75),
    "wood-beam": ((-1.0, 0.0), 1.05),
    "steel-plate": ((0.0, -1.0), 1.35),
}
SHELF_EDGE_M = 0.07      # shelf's inner edge: horizontal distance from the head's axis
SHELF_DEPTH_M = 0.30
SHELF_TILT_DEG = 9.0      # sag towards the head
SHELF_FRICTION = 0.32
COM_SETBACK_M = 0.03     # an object's centre of mass starts this far behind its shelf's edge
LEFT_SHELF_DROP_M = 0.05  # an object has left its shelf once it is this far below the edge
ROOM_MASS_KG = 5.0e4      # so heavy that contacts do not move it; its motion is prescribed anyway


@dataclass(frozen=True)
class Contact:
    """A head contact at its first step: object, time, approach speed along the normal, where in the room
    (``position``, m) and where on the head (``point`` and the outward ``normal``, head frame)."""

    object: str
    time_s: float
    velocity: float
    position: tuple[float, float, float]
    point: tuple[float, float, float]
    normal: tuple[float, float, float]


@dataclass
class SimulationResult:
    """What happened in the room: head contacts, when each object left its shelf, and timing."""

    contacts: list[Contact]
    left_shelf_s: dict[str, float | None]
    duration_s: float
    timestep_s: float
    steps: int
    notes: list[str] = field(default_factory=list)


def _box_half(obj: ObjectInfo) -> tuple[float, float, float]:
    """Half-sizes with the object lying flat: the two largest sizes horizontal."""
    w, h, d = sorted(obj.dimensions_mm, reverse=True)
    return (w / 2000.0, h / 2000.0, d / 2000.0)


def _tilted(yaw_deg: float, tilt_rad: float) -> str:
    """Quaternion (w x y z) of a yaw about z followed by a rise of ``tilt_rad`` about the local y."""
    yaw = np.radians(yaw_deg)
    qz = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    qy = np.array([np.cos(-tilt_rad / 2), 0.0, np.sin(-tilt_rad / 2), 0.0])
    w1, x1, y1, z1 = qz
    w2, x2, y2, z2 = qy
    q = (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)
    return " ".join(f"{c:.6f}" for c in q)


def build_mjcf(objects: dict[str, ObjectInfo] = PAPER_OBJECTS, *, timestep_s: float = 0.001) -> str:
    """The room as MJCF text (shelves around and above the head, one free box per object)."""
    tilt = np.radians(SHELF_TILT_DEG)
    shelves, boxes = [], []
    for oid, obj in objects.items():
        (dx, dy), drop = SHELVES[oid]
        hx, hy, hz = _box_half(obj)
        yaw = np.degrees(np.arctan2(dy, dx))
        # The shelf board: its top surface passes through the inner edge at the drop height;
        # it rises away from the head by the tilt.
        board_half = (SHELF_DEPTH_M / 2, hy + 0.012, 0.009)
        top_edge_z = HEAD_TOP_Z + drop
        cx = SHELF_EDGE_M + board_half[0] * np.cos(tilt)
        cz = top_edge_z + board_half[0] * np.sin(tilt) - board_half[2] * np.cos(tilt)
        shelves.append(
            f'<body name="shelf-{oid}" pos="{dx * cx:.5f} {dy * cx:.5f} {cz:.5f}" euler="0 0 {yaw:.3f}">'
            f'<geom name="shelf-{oid}" type="box" size="{board_half[0]} {board_half[1]} {board_half[2]}" '
            f'euler="0 {-SHELF_TILT_DEG} 0" friction="{SHELF_FRICTION} 0.005 0.0001" rgba=".55 .4 .25 1"/>'
            f'<geom type="box" size="0.01 {board_half[1]} 0.03" pos="{board_half[0]:.4f} 0 {board_half[0] * np.sin(tilt) + 0.02:.4f}" rgba=".55 .4 .25 1"/>'
            "</body>"
        )
        # The object overhangs the edge, its centre of mass just behind it.
        along = SHELF_EDGE_M + COM_SETBACK_M
        oz = top_edge_z + (along - SHELF_EDGE_M) * np.tan(tilt) + hz / np.cos(tilt) + 0.0005
        boxes.append(
            f'<body name="{oid}" pos="{dx * along:.5f} {dy * along:.5f} {oz:.5f}" quat="{_tilted(yaw, tilt)}">'
            f'<freejoint/><geom name="{oid}" type="box" size="{hx:.5f} {hy:.5f} {hz:.5f}" '
            f'mass="{obj.mass_kg}" friction="{SHELF_FRICTION} 0.005 0.0001" rgba=".8 .3 .2 1"/></body>'
        )
    return f"""<mujoco model="earthquake-room">
  <option timestep="{timestep_s}" gravity="0 0 -9.80665" integrator="implicitfast"/>
  <worldbody>
    <body name="room">
      <joint name="ground-x" type="slide" axis="1 0 0" damping="0"/>
      <joint name="ground-y" type="slide" axis="0 1 0" damping="0"/>
      <inertial pos="0 0 0" mass="{ROOM_MASS_KG}" diaginertia="1e5 1e5 1e5"/>
      <geom name="floor" type="box" size="3 3 0.05" pos="0 0 -0.05" rgba=".7 .7 .7 1"/>
      <geom name="torso" type="box" size="0.12 0.2 0.25" pos="0 0 1.25" rgba=".2 .3 .6 1"/>
      <geom name="neck" type="capsule" size="0.05" fromto="0 0 1.5 0 0 1.56" rgba=".9 .7 .6 1"/>
      <geom name="head" type="sphere" size="{HEAD_RADIUS}" pos="0 0 {HEAD_CENTRE_Z}" solref="0.004 1" rgba=".9 .8 .1 1"/>
      {"".join(shelves)}
    </body>
    {"".join(boxes)}
  </worldbody>
</mujoco>"""


def simulate(
    ground_x,
    ground_y=None,
    *,
    duration_s: float = 60.0,
    timestep_s: float = 0.001,
    min_velocity: float = 0.3,
    objects: dict[str, ObjectInfo] = PAPER_OBJECTS,
    on_contact=None,
    progress=None,
) -> SimulationResult:
    """Shake the room with ``ground_x`` (and ``ground_y``) GroundMotions; return the head contacts.

    A contact counts when a head-object pair that was apart at the previous
    step touches with an approach speed of at least ``min_velocity`` m/s
    (resting contact and slow rolling off the head do not count).
    ``on_contact(Contact)`` is called at the step each contact is found (the
    place where a simulator hands the impact to hapticfx); ``progress(fraction)``
    is called about once per simulated second.
    """
    import mujoco

    rate_hz = 1.0 / timestep_s
    n_steps = int(round(duration_s * rate_hz))
    motions = []
    for gm in (ground_x, ground_y):
        if gm is None:
            motions.append((np.zeros(n_steps), np.zeros(n_steps)))
            continue
        disp, vel, _ = gm.fitted_to(duration_s).kinematics(rate_hz)
        motions.append((disp[:n_steps], vel[:n_steps]))

    model = mujoco.MjModel.from_xml_string(build_mjcf(objects, timestep_s=timestep_s))
    data = mujoco.MjData(model)
    jx = model.joint("ground-x")
    jy = model.joint("ground-y")
    qx, qy = int(jx.qposadr[0]), int(jy.qposadr[0])
    vx, vy = int(jx.dofadr[0]), int(jy.dofadr[0])
    head = model.geom("head").id
    geom_object = {model.geom(oid).id: oid for oid in objects}
    body_of = {oid: model.body(oid).id for oid in objects}
    head_body = int(model.geom_bodyid[head])

    contacts: list[Contact] = []
    touching: set[str] = set()
    fallen_below = {oid: HEAD_TOP_Z + SHELVES[oid][1] - LEFT_SHELF_DROP_M for oid in objects}
    left_shelf: dict[str, float | None] = {oid: None for oid in objects}
    jacp_a = np.zeros((3, model.nv))
    jacp_b = np.zeros((3, model.nv))
    mujoco.mj_forward(model, data)
    settle_s = 0.2  # let the objects settle on their shelves before the ground moves
    report_every = int(rate_hz)
    for i in range(n_steps):
        t = i * timestep_s
        k = max(0, i - int(settle_s * rate_hz))
        data.qpos[qx], data.qvel[vx] = motions[0][0][k], motions[0][1][k]
        data.qpos[qy], data.qvel[vy] = motions[1][0][k], motions[1][1][k]
        mujoco.mj_step1(model, data)
        now_touching = set()
        ncon = data.ncon
        if ncon:
            pairs = data.contact.geom[:ncon]
            for c in np.flatnonzero((pairs[:, 0] == head) | (pairs[:, 1] == head)):
                other = int(pairs[c, 1] if pairs[c, 0] == head else pairs[c, 0])
                oid = geom_object.get(other)
                if oid is None:
                    continue
                now_touching.add(oid)
                if oid in touching:
                    continue
                con = data.contact[c]
                point = np.array(con.pos)
                normal = np.array(con.frame[:3])
                mujoco.mj_jac(model, data, jacp_a, None, point, body_of[oid])
                mujoco.mj_jac(model, data, jacp_b, None, point, head_body)
                rel = (jacp_a - jacp_b) @ data.qvel
                speed = abs(float(rel @ normal))
                if speed >= min_velocity:
                    on_head = point - data.geom_xpos[head]  # the room moves, it does not turn: the room's axes
                    if normal @ on_head < 0:
                        normal = -normal  # MuJoCo's normal points from the first geom to the second: outwards here
                    contact = Contact(oid, t, speed, tuple(float(p) for p in point), tuple(float(p) for p in on_head),
                                      tuple(float(n) for n in normal))
                    contacts.append(contact)
                    if on_contact is not None:
                        on_contact(contact)
        touching = now_touching
        for oid in objects:
            if left_shelf[oid] is None and data.xpos[body_of[oid], 2] < fallen_below[oid]:
                left_shelf[oid] = t
        mujoco.mj_step2(model, data)
        if progress is not None and i % report_every == 0:
            progress(i / n_steps)

    notes = []
    hit = {c.object for c in contacts}
    for oid in objects:
        if left_shelf[oid] is None:
            notes.append(f"{oid}: stayed on its shelf for the whole {duration_s:g} s")
        elif oid not in hit:
            notes.append(f"{oid}: left its shelf at {left_shelf[oid]:.2f} s but did not hit the head")
    return SimulationResult(contacts, left_shelf, duration_s, timestep_s, n_steps, notes)
