# HapticfxObject.gd - put on a RigidBody that can fall on the head; sends each head contact to hapticfx.
#
# The impact velocity is the closing speed along the contact normal BEFORE the physics solver resolved the
# contact: Godot reports a contact (here, and in body_entered) after the step that resolved it, when the body
# has already (nearly) stopped, so the velocities kept from the previous physics steps are the ones to use.
# A thin, fast object can even be stopped one step before its contact is first reported (Godot 3's Bullet
# drops a contact the solver already separated): the largest closing speed over the last few steps covers it.
extends RigidBody

export var object_id = "concrete-brick"     # a key of the scene's `effects`
export var min_velocity = 0.3               # slower contacts are resting or rolling, not impacts (m/s)

var head: PhysicsBody = null                # the head's body
var head_velocity_fn: FuncRef = null        # the head's velocity now (Vector3), if it moves
var osc = null                              # a HapticfxOsc
var clock_fn: FuncRef = null                # the simulation time (s)

const STEPS_KEPT = 3
var _velocities = []                        # this body's velocity at the end of the last STEPS_KEPT steps
var _touching = false

signal impact(object_id, velocity, point, normal)


func _ready():
	contact_monitor = true
	contacts_reported = 4


func _integrate_forces(state: PhysicsDirectBodyState):
	var found = -1
	for i in range(state.get_contact_count()):
		if state.get_contact_collider_object(i) == head:
			found = i
			break
	if found >= 0 and not _touching:
		_report(state, found)
	_touching = found >= 0
	_velocities.push_back(state.linear_velocity)
	if _velocities.size() > STEPS_KEPT:
		_velocities.pop_front()


func _report(state: PhysicsDirectBodyState, i: int) -> void:
	var point = state.get_contact_collider_position(i)  # global coordinates
	var centre = head.global_transform.origin
	var normal = state.get_contact_local_normal(i)      # global orientation
	if normal.dot(point - centre) < 0:
		normal = -normal  # the head frame's normal points from the head towards the object
	var head_velocity = head_velocity_fn.call_func() if head_velocity_fn else Vector3.ZERO
	var speed = 0.0
	for v in _velocities:  # closing: moving against the outward normal
		speed = max(speed, -(v - head_velocity).dot(normal))
	if speed < min_velocity:
		return
	var to_head = head.global_transform.affine_inverse()
	var p = osc.head_frame(to_head.xform(point))
	var n = osc.head_frame(to_head.basis.xform(normal)).normalized()
	var t = clock_fn.call_func() if clock_fn else OS.get_ticks_msec() / 1000.0
	osc.send_impact(object_id, speed, t, p, n)
	emit_signal("impact", object_id, speed, p, n)
