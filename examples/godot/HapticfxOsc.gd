# HapticfxOsc.gd - sends impacts to `hapticfx serve` as OSC over UDP (docs/protocol.md, version 2).
# No add-on needed: the OSC bytes are built here. Sending never waits: a UDP datagram is queued and
# the call returns.
extends Reference

var _udp = PacketPeerUDP.new()


func open(host: String, port: int) -> int:
	return _udp.set_dest_address(host, port)


# /hapticfx/impact ,sfidffffff object velocity -1 time point normal.
# velocity: closing speed along the contact normal (m/s); sim_time: the engine's time (s, sent as a double);
# point, normal: in the head frame (x right, y forward, z up; metres from the head's centre), see head_frame().
func send_impact(object_id: String, velocity: float, sim_time: float, point: Vector3, normal: Vector3) -> int:
	return _udp.put_packet(build_impact(object_id, velocity, sim_time, point, normal))


static func build_impact(object_id: String, velocity: float, sim_time: float, point: Vector3, normal: Vector3) -> PoolByteArray:
	var buf = StreamPeerBuffer.new()
	buf.big_endian = true  # OSC is big-endian
	_put_string(buf, "/hapticfx/impact")
	_put_string(buf, ",sfidffffff")
	_put_string(buf, object_id)
	buf.put_float(velocity)
	buf.put_32(-1)  # the channel the scene wires the object to
	buf.put_double(sim_time)
	for v in [point, normal]:
		buf.put_float(v.x)
		buf.put_float(v.y)
		buf.put_float(v.z)
	return buf.data_array


# Godot's axes (x right, y up, -z forward) in the head's local space -> the head frame (x right, y forward, z up).
static func head_frame(v: Vector3) -> Vector3:
	return Vector3(v.x, -v.z, v.y)


# An OSC string: UTF-8, a NUL, then NULs up to a multiple of 4 bytes.
static func _put_string(buf: StreamPeerBuffer, text: String) -> void:
	var raw = text.to_utf8()
	buf.put_data(raw)
	for _i in range(4 - raw.size() % 4):
		buf.put_8(0)
