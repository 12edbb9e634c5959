# Room.gd - the paper's scene in Godot 3: a room shaken by an earthquake, a standing person's head, and the
# paper's four objects on shelves above it. The shaking knocks the shelves' objects off one after another
# (lowest first); each falls on the head, and its contact goes to `hapticfx serve` as an OSC impact
# (HapticfxObject.gd). The scene quits by itself when the last object has fallen.
#
#   hapticfx serve scenes/earthquake_room.yaml          # in one shell
#   godot3 --path examples/godot                        # in another (godot3-server headless)
#
# Environment: HAPTICFX_HOST / HAPTICFX_PORT (default 127.0.0.1:9000) say where `hapticfx serve` listens.
extends Spatial

const HapticfxOsc = preload("res://HapticfxOsc.gd")
const HapticfxObject = preload("res://HapticfxObject.gd")

const HEAD_RADIUS = 0.13                 # the head in the paper's safety helmet (m)
const HEAD_CENTRE_Y = 1.62               # standing
const SHAKE_AMPLITUDE = Vector3(0.005, 0.0, 0.004)   # the room's horizontal displacement (m)
const SHAKE_HZ = Vector3(2.1, 0.0, 1.7)
# id, mass (kg), size lying flat (x, y, z; m), drop height of its underside above the top of the head (m),
# when the shaking knocks it off its shelf (s)
const OBJECTS = [
	["plastic-frame", 0.035, Vector3(0.0819, 0.0447, 0.0534), 0.45, 0.25],
	["concrete-brick", 0.069, Vector3(0.0483, 0.0146, 0.0365), 0.75, 1.05],
	["wood-beam", 0.150, Vector3(0.0983, 0.0356, 0.0582), 1.05, 1.85],
	["steel-plate", 0.200, Vector3(0.1, 0.0048, 0.1), 1.35, 2.65],
]
const LINGER_S = 0.35                    # an object is taken away this long after it hit the head
const END_S = 3.6                        # quit then

var osc = HapticfxOsc.new()
var time_s = 0.0
var room: Spatial
var head: KinematicBody
var held = {}                            # object -> [release time, place on its shelf]: moving with the room
var hit_at = {}                          # object -> when it hit the head
var impacts = 0


func _ready():
	var host = OS.get_environment("HAPTICFX_HOST")
	var port = OS.get_environment("HAPTICFX_PORT")
	var err = osc.open(host if host != "" else "127.0.0.1", int(port) if port != "" else 9000)
	if err != OK:
		printerr("hapticfx: cannot send to %s:%s (error %d)" % [host, port, err])
	room = Spatial.new()
	room.name = "ShakingRoom"
	add_child(room)
	room.add_child(_static_box("Floor", Vector3(6, 0.1, 6), Vector3(0, -0.05, 0)))
	head = KinematicBody.new()
	head.name = "Head"
	var sphere = SphereShape.new()
	sphere.radius = HEAD_RADIUS
	head.add_child(_shape(sphere))
	head.translation = Vector3(0, HEAD_CENTRE_Y, 0)
	room.add_child(head)
	for spec in OBJECTS:
		_add_object(spec)


func _add_object(spec) -> void:
	var body = HapticfxObject.new()
	body.name = spec[0]
	body.object_id = spec[0]
	body.mass = spec[1]
	var box = BoxShape.new()
	box.extents = spec[2] / 2
	body.add_child(_shape(box))
	body.mode = RigidBody.MODE_KINEMATIC  # held by its shelf until the shaking knocks it off
	body.head = head
	body.head_velocity_fn = funcref(self, "room_velocity")
	body.clock_fn = funcref(self, "now")
	body.osc = osc
	body.connect("impact", self, "_on_impact")
	var bottom = HEAD_CENTRE_Y + HEAD_RADIUS + spec[3]
	var place = Vector3(0, bottom + spec[2].y / 2, 0)
	body.translation = place
	add_child(body)  # not the room's child: a rigid body under a moving parent would be carried, not fall
	held[body] = [spec[4], place]


func _physics_process(delta):
	time_s += delta
	room.translation = room_offset(time_s)
	for body in held.keys():
		if time_s < held[body][0]:
			body.translation = held[body][1] + room.translation
		else:  # knocked off: it leaves with the room's velocity
			held.erase(body)
			body.mode = RigidBody.MODE_RIGID
			body.linear_velocity = room_velocity()
	for body in hit_at.keys():
		if time_s - hit_at[body] > LINGER_S:  # bounced off: clear the way for the next one
			hit_at.erase(body)
			body.queue_free()
	if time_s >= END_S:
		print("hapticfx: %d impact(s) sent; quitting" % impacts)
		get_tree().quit()


func _on_impact(object_id, velocity, point, normal):
	impacts += 1
	hit_at[get_node(object_id)] = time_s
	print("hapticfx: impact %s %.4f m/s at %.4f s, point (%.4f, %.4f, %.4f), normal (%.3f, %.3f, %.3f)" % [
		object_id, velocity, time_s, point.x, point.y, point.z, normal.x, normal.y, normal.z])


func now() -> float:
	return time_s


func room_offset(t: float) -> Vector3:
	var w = 2 * PI * SHAKE_HZ
	return Vector3(SHAKE_AMPLITUDE.x * sin(w.x * t), 0, SHAKE_AMPLITUDE.z * sin(w.z * t))


func room_velocity() -> Vector3:
	var w = 2 * PI * SHAKE_HZ
	return Vector3(SHAKE_AMPLITUDE.x * w.x * cos(w.x * time_s), 0, SHAKE_AMPLITUDE.z * w.z * cos(w.z * time_s))


func _shape(shape: Shape) -> CollisionShape:
	shape.margin = 0.001  # Bullet's default 4 cm margin rounds the paper's small objects and meets them early
	var node = CollisionShape.new()
	node.shape = shape
	return node


func _static_box(name: String, size: Vector3, at: Vector3) -> StaticBody:
	var body = StaticBody.new()
	body.name = name
	var box = BoxShape.new()
	box.extents = size / 2
	body.add_child(_shape(box))
	body.translation = at
	return body
