class_name Mannequin
extends RefCounted
## A procedural humanoid mannequin: a Skeleton3D named with Godot's
## SkeletonProfileHumanoid bones, in an A-pose, with one smoothly skinned mesh
## (superellipse cross-sections lofted along each bone chain) and an orange
## visor on the head, so its facing shows at a glance.
##
## About 1.75 m tall, facing +Z (its left side at +X), feet on y = 0 at rest.
## Each bone's local +Y points along the bone to its child (the glTF / Blender
## convention). The rig deliberately differs from the motion model's own
## (names, A-pose, bone frames, an extra UpperChest, proportions), so it
## exercises the MotionGenerator's retargeting. The mesh and skin are built
## once and shared by every mannequin.

## The character faces +Z (Godot's Vector3.BACK); its left side is +X.
const FORWARD := Vector3(0, 0, 1)
const BODY_COLOR := Color(0.52, 0.57, 0.66)
const MARKER_COLOR := Color(1.0, 0.48, 0.1)
## Arms hang this far below horizontal at rest (A-pose).
const ARM_ANGLE := deg_to_rad(42.0)
const UPPER_ARM := 0.29
const LOWER_ARM := 0.255
const SIDES := 20
const TORSO_SIDES := 28

## Bone, parent, head position at rest (skeleton space). The left side is
## listed once (without "Left") and mirrored for the right.
const _CENTRE := [
	["Hips", "", Vector3(0, 0.985, 0)],
	["Spine", "Hips", Vector3(0, 1.085, -0.005)],
	["Chest", "Spine", Vector3(0, 1.205, -0.012)],
	["UpperChest", "Chest", Vector3(0, 1.32, -0.015)],
	["Neck", "UpperChest", Vector3(0, 1.48, -0.02)],
	["Head", "Neck", Vector3(0, 1.575, -0.005)],
]
const _SIDE := [
	["Shoulder", "UpperChest", Vector3(0.025, 1.425, -0.01)],
	["UpperArm", "Shoulder", Vector3(0.175, 1.415, -0.025)],
	["LowerArm", "UpperArm", Vector3.ZERO],  # placed along the arm
	["Hand", "LowerArm", Vector3.ZERO],
	["UpperLeg", "Hips", Vector3(0.09, 0.955, 0)],
	["LowerLeg", "UpperLeg", Vector3(0.095, 0.54, 0.01)],
	["Foot", "LowerLeg", Vector3(0.1, 0.098, -0.01)],
	["Toes", "Foot", Vector3(0.1, 0.035, 0.095)],
]

# Ghosts draw in two passes. The first writes only depth, so the second
# shades only the nearest surface: the ends of the limbs inside the body and
# overlapping parts do not show through as darker layers.
const _GHOST_DEPTH_SHADER := """
shader_type spatial;
render_mode unshaded, cull_back, depth_draw_always;
void fragment() {
	ALBEDO = vec3(0.0);
	ALPHA = 0.0;
}
"""
# The rim keeps the silhouette readable.
const _GHOST_SHADER := """
shader_type spatial;
render_mode unshaded, cull_back, depth_draw_never;
uniform vec4 color : source_color = vec4(0.3, 0.7, 1.0, 0.35);
void fragment() {
	float rim = pow(1.0 - clamp(dot(NORMAL, VIEW), 0.0, 1.0), 2.0);
	ALBEDO = mix(color.rgb, vec3(1.0), rim * 0.35);
	ALPHA = clamp(color.a + rim * 0.45, 0.0, 1.0);
}
"""

static var _mesh: ArrayMesh
static var _skin: Skin
static var _body_material: StandardMaterial3D
static var _marker_material: StandardMaterial3D
static var _ghost_shaders: Array[Shader] = []
## Seconds the shared mesh took to build (for the demo's figures).
static var build_seconds := 0.0


## A mannequin with its matte body and orange visor.
static func build() -> Skeleton3D:
	var skeleton := _skeleton()
	var mesh := _mesh_instance(skeleton)
	if _body_material == null:
		_body_material = StandardMaterial3D.new()
		_body_material.albedo_color = BODY_COLOR
		_body_material.roughness = 0.8
		_marker_material = StandardMaterial3D.new()
		_marker_material.albedo_color = MARKER_COLOR
		_marker_material.roughness = 0.35
	mesh.set_surface_override_material(0, _body_material)
	mesh.set_surface_override_material(1, _marker_material)
	return skeleton


## The same mannequin, translucent and unlit but for a rim, in `color` (its
## alpha sets how solid the body looks); for showing a target pose.
static func build_ghost(color: Color) -> Skeleton3D:
	var skeleton := _skeleton()
	var mesh := _mesh_instance(skeleton)
	mesh.cast_shadow = GeometryInstance3D.SHADOW_CASTING_SETTING_OFF
	if _ghost_shaders.is_empty():
		for code: String in [_GHOST_DEPTH_SHADER, _GHOST_SHADER]:
			var shader := Shader.new()
			shader.code = code
			_ghost_shaders.append(shader)
	# One material for body and visor: two different override materials on
	# one instance make the headless renderer report errors when it is freed.
	var shaded := ShaderMaterial.new()
	shaded.shader = _ghost_shaders[1]
	shaded.set_shader_parameter("color", color)
	var depth := ShaderMaterial.new()
	depth.shader = _ghost_shaders[0]
	depth.render_priority = -1  # before the shaded pass
	depth.next_pass = shaded
	mesh.material_override = depth
	return skeleton


## Rest head positions by bone name, the right side mirrored from the left.
static func rest_heads() -> Dictionary:
	var heads := {}
	for row: Array in _CENTRE:
		heads[row[0]] = row[2]
	var arm := Vector3(cos(ARM_ANGLE), -sin(ARM_ANGLE), 0)
	for side: String in ["Left", "Right"]:
		var mirror := Vector3(1 if side == "Left" else -1, 1, 1)
		for row: Array in _SIDE:
			heads[side + row[0]] = row[2] * mirror
		var elbow: Vector3 = heads[side + "UpperArm"] + arm * mirror * UPPER_ARM
		heads[side + "LowerArm"] = elbow
		heads[side + "Hand"] = elbow + arm * mirror * LOWER_ARM
	return heads


static func _skeleton() -> Skeleton3D:
	var skeleton := Skeleton3D.new()
	skeleton.name = "Skeleton3D"
	var heads := rest_heads()
	var globals := _rest_globals(heads)
	for row: Array in _bone_rows():
		var bone := skeleton.add_bone(row[0])
		var parent := skeleton.find_bone(row[1])
		var rest: Transform3D = globals[row[0]]
		if parent >= 0:
			skeleton.set_bone_parent(bone, parent)
			rest = (globals[row[1]] as Transform3D).affine_inverse() * rest
		skeleton.set_bone_rest(bone, rest)
	skeleton.reset_bone_poses()
	return skeleton


static func _mesh_instance(skeleton: Skeleton3D) -> MeshInstance3D:
	if _mesh == null:
		_build_mesh(skeleton)
	var mesh := MeshInstance3D.new()
	mesh.name = "Body"
	mesh.mesh = _mesh
	mesh.skin = _skin
	mesh.skeleton = NodePath("..")
	skeleton.add_child(mesh)
	return mesh


# Name and parent of every bone, parents first.
static func _bone_rows() -> Array:
	var rows := []
	for row: Array in _CENTRE:
		rows.append([row[0], row[1]])
	for side: String in ["Left", "Right"]:
		for row: Array in _SIDE:
			var parent: String = row[1]
			if parent != "Hips" and parent != "UpperChest":
				parent = side + parent
			rows.append([side + row[0], parent])
	return rows


# Global rest transforms: +Y along the bone to its child (or on along the
# limb for the leaves), +Z as close to the body's forward as that allows (up,
# for the feet, which point forward).
static func _rest_globals(heads: Dictionary) -> Dictionary:
	var tails := {
		"Hips": heads["Spine"],
		"Spine": heads["Chest"],
		"Chest": heads["UpperChest"],
		"UpperChest": heads["Neck"],
		"Neck": heads["Head"],
		"Head": Vector3(0, 1.75, -0.005),
	}
	for side: String in ["Left", "Right"]:
		var hand: Vector3 = heads[side + "Hand"]
		tails[side + "Shoulder"] = heads[side + "UpperArm"]
		tails[side + "UpperArm"] = heads[side + "LowerArm"]
		tails[side + "LowerArm"] = hand
		tails[side + "Hand"] = hand + (hand - heads[side + "LowerArm"]).normalized() * 0.1
		tails[side + "UpperLeg"] = heads[side + "LowerLeg"]
		tails[side + "LowerLeg"] = heads[side + "Foot"]
		tails[side + "Foot"] = heads[side + "Toes"]
		tails[side + "Toes"] = heads[side + "Toes"] + Vector3(0, -0.005, 0.07)
	var globals := {}
	for bone: String in heads:
		var y: Vector3 = ((tails[bone] as Vector3) - heads[bone]).normalized()
		var reference := Vector3.UP if bone.ends_with("Foot") or bone.ends_with("Toes") else FORWARD
		var x := y.cross(reference).normalized()
		globals[bone] = Transform3D(Basis(x, y, x.cross(y)), heads[bone])
	return globals


static func _build_mesh(skeleton: Skeleton3D) -> void:
	var started := Time.get_ticks_usec()
	var body := _MeshData.new()
	var marker := _MeshData.new()
	var heads := rest_heads()
	var bone := func(bone_name: String) -> int: return skeleton.find_bone(bone_name)
	_add_torso(body, heads, bone)
	_add_head(body, marker, bone)
	for side: String in ["Left", "Right"]:
		var mirror := 1.0 if side == "Left" else -1.0
		_add_leg(body, heads, side, mirror, bone)
		_add_foot(body, heads, side, bone)
		_add_arm(body, heads, side, mirror, bone)
		_add_hand(body, heads, side, mirror, bone)
	_mesh = ArrayMesh.new()
	_mesh.add_surface_from_arrays(Mesh.PRIMITIVE_TRIANGLES, body.arrays())
	_mesh.add_surface_from_arrays(Mesh.PRIMITIVE_TRIANGLES, marker.arrays())
	_skin = Skin.new()
	for i in skeleton.get_bone_count():
		_skin.add_named_bind(
			skeleton.get_bone_name(i), skeleton.get_bone_global_rest(i).affine_inverse()
		)
	build_seconds = (Time.get_ticks_usec() - started) / 1e6


# Weights that hand over from bones[i] to bones[i + 1] around joints[i]
# (x: position along the part, y: half-width of the blend), as {bone: weight}.
static func _blend(bones: PackedInt32Array, joints: PackedVector2Array, s: float) -> Dictionary:
	var weights := {}
	var previous := 1.0
	for i in joints.size():
		var f := smoothstep(joints[i].x - joints[i].y, joints[i].x + joints[i].y, s)
		if previous - f > 1e-4:
			weights[bones[i]] = previous - f
		previous = f
	if previous > 1e-4:
		weights[bones[joints.size()]] = weights.get(bones[joints.size()], 0.0) + previous
	return weights


static func _add_torso(body: _MeshData, heads: Dictionary, bone: Callable) -> void:
	# y, half-width, half-depth, centre z: pelvis, waist, chest, shoulders.
	var rings := [
		[0.855, 0.0, 0.0, -0.005],
		[0.87, 0.065, 0.055, -0.005],
		[0.895, 0.125, 0.088, -0.01],
		[0.93, 0.158, 0.103, -0.012],
		[0.985, 0.163, 0.104, -0.01],
		[1.045, 0.148, 0.095, -0.005],
		[1.105, 0.135, 0.088, 0.0],
		[1.165, 0.14, 0.092, 0.002],
		[1.235, 0.152, 0.1, 0.004],
		[1.305, 0.163, 0.106, 0.002],
		[1.37, 0.17, 0.102, -0.004],
		[1.415, 0.165, 0.093, -0.01],
		[1.45, 0.135, 0.08, -0.015],
		[1.48, 0.095, 0.066, -0.02],
		[1.5, 0.0, 0.0, -0.02],
	]
	var bones := PackedInt32Array()
	var joints := PackedVector2Array()
	for name: String in ["Hips", "Spine", "Chest", "UpperChest", "Neck"]:
		bones.append(bone.call(name))
		if name != "Hips":
			joints.append(Vector2((heads[name] as Vector3).y, 0.05))
	var loft := _Loft.new(TORSO_SIDES, 2.6)
	for ring: Array in rings:
		var y: float = ring[0]
		loft.add(
			Vector3(0, y, ring[3]),
			Vector3(ring[1], 0, 0),
			Vector3(0, 0, ring[2]),
			_blend(bones, joints, y)
		)
	var sides := {}
	for side: String in ["Left", "Right"]:
		sides[side] = [bone.call(side + "UpperLeg"), bone.call(side + "Shoulder")]
	# The pelvis below the hip joints goes partly with the thighs, the top
	# corners with the collarbones, so neither seam opens when they move.
	loft.adjust = func(p: Vector3, weights: Dictionary) -> Dictionary:
		var side: Array = sides["Left" if p.x >= 0.0 else "Right"]
		var ax := absf(p.x)
		var leg := (1.0 - smoothstep(0.885, 0.975, p.y)) * smoothstep(0.015, 0.08, ax) * 0.75
		var shoulder := smoothstep(1.3, 1.41, p.y) * smoothstep(0.05, 0.14, ax) * 0.85
		var result := {}
		for b: int in weights:
			result[b] = weights[b] * (1.0 - leg - shoulder)
		result[side[0]] = result.get(side[0], 0.0) + leg
		result[side[1]] = result.get(side[1], 0.0) + shoulder
		return result
	body.add_loft(loft)
	# The neck, from inside the chest to inside the head.
	var neck := _Loft.new(SIDES, 2.0)
	var neck_bones := PackedInt32Array(
		[bone.call("UpperChest"), bone.call("Neck"), bone.call("Head")]
	)
	var neck_joints := PackedVector2Array([Vector2(1.47, 0.035), Vector2(1.585, 0.03)])
	for ring: Array in [
		[1.42, 0.0],
		[1.43, 0.05],
		[1.46, 0.058],
		[1.52, 0.054],
		[1.58, 0.051],
		[1.62, 0.045],
		[1.63, 0.0]
	]:
		var y: float = ring[0]
		var z := lerpf(-0.03, -0.005, inverse_lerp(1.42, 1.63, y))
		var r: float = ring[1]
		neck.add(
			Vector3(0, y, z),
			Vector3(r, 0, 0),
			Vector3(0, 0, r * 1.05),
			_blend(neck_bones, neck_joints, y)
		)
	body.add_loft(neck)


static func _add_head(body: _MeshData, marker: _MeshData, bone: Callable) -> void:
	var head := _head_shape()
	var centre: Vector3 = head[0]
	var weights := {bone.call("Head"): 1.0}
	var loft := _Loft.new(SIDES, 2.0)
	var rings := 14
	for i in rings + 1:
		var k := -cos(PI * i / rings)  # denser near the poles
		var radii := _head_radii(k)
		var y := centre.y + k * (head[1] as float)
		loft.add(
			Vector3(0, y, centre.z + radii.z),
			Vector3(radii.x, 0, 0),
			Vector3(0, 0, radii.y),
			weights
		)
	body.add_loft(loft)
	# Nose: a short blunt cone out of the face.
	var nose := _Loft.new(12, 2.0)
	var nose_y := centre.y - 0.028
	var face_z := centre.z + _head_depth_at(nose_y)
	for ring: Array in [[-0.012, 0.015], [0.01, 0.014], [0.022, 0.009], [0.028, 0.0]]:
		var r: float = ring[1]
		nose.add(
			Vector3(0, nose_y - 0.004 * ring[0] / 0.028, face_z + ring[0]),
			Vector3(r * 0.8, 0, 0),
			Vector3(0, r, 0),
			weights
		)
	body.add_loft(nose)
	# Visor: a band around the front of the head at eye height.
	var visor := _Loft.new(10, 2.4)
	var visor_y := centre.y + 0.012
	var radii := _head_radii((visor_y - centre.y) / (head[1] as float))
	var steps := 16
	for i in steps + 1:
		var angle := lerpf(-1.25, 1.25, float(i) / steps)
		var outward := Vector3(sin(angle) * radii.y, 0, cos(angle) * radii.x).normalized()
		var point := Vector3(
			sin(angle) * radii.x, visor_y, centre.z + radii.z + cos(angle) * radii.y
		)
		var ends := i == 0 or i == steps
		var height := 0.0 if ends else 0.022 * sqrt(1.0 - pow(2.0 * i / steps - 1.0, 8.0))
		var thickness := 0.0 if ends else 0.012
		visor.add(point + outward * 0.003, Vector3(0, height, 0), outward * thickness, weights)
	marker.add_loft(visor)


# Centre and half-height of the head's egg.
static func _head_shape() -> Array:
	return [Vector3(0, 1.645, 0.012), 0.105]


# Half-width, half-depth and forward shift of the head at height k (-1 chin,
# 1 crown): an egg, narrower at the jaw.
static func _head_radii(k: float) -> Vector3:
	var r := sqrt(maxf(0.0, 1.0 - k * k))
	var jaw := maxf(0.0, -k)
	return Vector3(0.08 * r * (1.0 - 0.2 * jaw), 0.1 * r, 0.012 * jaw)


static func _head_depth_at(y: float) -> float:
	var head := _head_shape()
	var k := (y - (head[0] as Vector3).y) / (head[1] as float)
	var radii := _head_radii(k)
	return radii.z + radii.y


static func _add_leg(
	body: _MeshData, heads: Dictionary, side: String, mirror: float, bone: Callable
) -> void:
	var points := PackedVector3Array(
		[heads[side + "UpperLeg"], heads[side + "LowerLeg"], heads[side + "Foot"]]
	)
	var bones := PackedInt32Array(
		[
			bone.call("Hips"),
			bone.call(side + "UpperLeg"),
			bone.call(side + "LowerLeg"),
			bone.call(side + "Foot")
		]
	)
	# Segment, fraction, half-width, half-depth, forward shift (calf back).
	var stations := [
		[0, -0.14, 0.0, 0.0, 0.0],
		[0, -0.12, 0.045, 0.045, 0.0],
		[0, -0.07, 0.075, 0.078, 0.0],
		[0, 0.0, 0.082, 0.086, 0.0],
		[0, 0.15, 0.081, 0.084, 0.002],
		[0, 0.38, 0.073, 0.076, 0.004],
		[0, 0.6, 0.063, 0.066, 0.004],
		[0, 0.8, 0.053, 0.056, 0.002],
		[0, 0.93, 0.049, 0.053, 0.003],
		[1, 0.0, 0.047, 0.052, 0.004],
		[1, 0.08, 0.047, 0.051, 0.0],
		[1, 0.22, 0.051, 0.056, -0.01],
		[1, 0.38, 0.049, 0.052, -0.01],
		[1, 0.58, 0.041, 0.042, -0.006],
		[1, 0.8, 0.034, 0.035, -0.002],
		[1, 0.96, 0.031, 0.032, 0.0],
		[1, 1.06, 0.024, 0.026, 0.0],
		[1, 1.1, 0.0, 0.0, 0.0],
	]
	var thigh := points[0].distance_to(points[1])
	var shin := points[1].distance_to(points[2])
	# The thigh turns as one piece inside the pelvis; knee and ankle blend.
	var joints := PackedVector2Array(
		[Vector2(-0.07, 0.02), Vector2(thigh, 0.05), Vector2(thigh + shin, 0.03)]
	)
	body.add_loft(_chain(points, bones, joints, stations, FORWARD, mirror))


static func _add_arm(
	body: _MeshData, heads: Dictionary, side: String, mirror: float, bone: Callable
) -> void:
	var points := PackedVector3Array(
		[heads[side + "UpperArm"], heads[side + "LowerArm"], heads[side + "Hand"]]
	)
	var bones := PackedInt32Array(
		[
			bone.call(side + "Shoulder"),
			bone.call(side + "UpperArm"),
			bone.call(side + "LowerArm"),
			bone.call(side + "Hand"),
		]
	)
	var stations := [
		[0, -0.24, 0.0, 0.0, 0.0],
		[0, -0.22, 0.03, 0.03, 0.0],
		[0, -0.15, 0.05, 0.05, 0.0],
		[0, -0.05, 0.058, 0.058, 0.0],
		[0, 0.08, 0.056, 0.055, 0.0],
		[0, 0.25, 0.05, 0.048, 0.0],
		[0, 0.5, 0.045, 0.043, 0.0],
		[0, 0.75, 0.04, 0.039, 0.0],
		[0, 0.92, 0.037, 0.036, -0.002],
		[1, 0.0, 0.036, 0.036, -0.003],
		[1, 0.12, 0.04, 0.038, 0.0],
		[1, 0.35, 0.039, 0.034, 0.0],
		[1, 0.65, 0.033, 0.029, 0.0],
		[1, 0.93, 0.022, 0.028, 0.0],
		[1, 1.05, 0.017, 0.022, 0.0],
		[1, 1.08, 0.0, 0.0, 0.0],
	]
	var upper := points[0].distance_to(points[1])
	var lower := points[1].distance_to(points[2])
	var joints := PackedVector2Array(
		[Vector2(-0.03, 0.03), Vector2(upper, 0.045), Vector2(upper + lower, 0.025)]
	)
	body.add_loft(_chain(points, bones, joints, stations, FORWARD, mirror))


static func _add_hand(
	body: _MeshData, heads: Dictionary, side: String, mirror: float, bone: Callable
) -> void:
	var wrist: Vector3 = heads[side + "Hand"]
	var along := (wrist - (heads[side + "LowerArm"] as Vector3)).normalized()
	# The palm faces the thigh: its flat side is across the arm in the body's
	# front plane, its width forward.
	var across := along.cross(FORWARD).normalized()
	var bones := PackedInt32Array([bone.call(side + "LowerArm"), bone.call(side + "Hand")])
	var joints := PackedVector2Array([Vector2(0.0, 0.02)])
	var loft := _Loft.new(SIDES, 2.8)
	var stations := [
		[-0.02, 0.0, 0.0],
		[-0.015, 0.015, 0.02],
		[0.0, 0.019, 0.027],
		[0.04, 0.02, 0.039],
		[0.08, 0.018, 0.043],
		[0.11, 0.015, 0.042],
		[0.15, 0.012, 0.037],
		[0.175, 0.009, 0.029],
		[0.19, 0.0, 0.0],
	]
	for station: Array in stations:
		var s: float = station[0]
		var centre := wrist + along * s + Vector3(0, 0, 0.006)
		loft.add(centre, across * station[1], FORWARD * station[2], _blend(bones, joints, s))
	body.add_loft(loft)
	# Thumb, forward and down from the base of the palm.
	var thumb := _Loft.new(10, 2.0)
	var base := wrist + along * 0.035 + Vector3(0, 0, 0.03)
	var direction := (along + Vector3(0, 0, 0.9) - across * mirror * 0.2).normalized()
	var hand_only := {bone.call(side + "Hand"): 1.0}
	var side_axis := direction.cross(Vector3.UP).normalized()
	var up_axis := side_axis.cross(direction).normalized()
	for ring: Array in [[-0.01, 0.0], [0.0, 0.014], [0.03, 0.012], [0.055, 0.01], [0.065, 0.0]]:
		var r: float = ring[1]
		thumb.add(base + direction * ring[0], side_axis * r, up_axis * r, hand_only)
	body.add_loft(thumb)


static func _add_foot(body: _MeshData, heads: Dictionary, side: String, bone: Callable) -> void:
	var ankle: Vector3 = heads[side + "Foot"]
	var ball: Vector3 = heads[side + "Toes"]
	var bones := PackedInt32Array([bone.call(side + "Foot"), bone.call(side + "Toes")])
	var joints := PackedVector2Array([Vector2(ball.z, 0.02)])
	# z from the ankle, half-width, height of the top (the sole is y = 0).
	var stations := [
		[-0.082, 0.0, 0.05],
		[-0.078, 0.026, 0.055],
		[-0.065, 0.036, 0.085],
		[-0.03, 0.041, 0.115],
		[0.01, 0.044, 0.115],
		[0.05, 0.047, 0.085],
		[0.09, 0.05, 0.06],
		[0.13, 0.049, 0.047],
		[0.16, 0.044, 0.038],
		[0.178, 0.034, 0.03],
		[0.186, 0.0, 0.022],
	]
	var loft := _Loft.new(SIDES, 4.0)
	for station: Array in stations:
		var z: float = ankle.z + station[0]
		var top: float = station[2]
		var centre := Vector3(ankle.x, top * 0.5, z)
		var height := 0.0 if is_zero_approx(station[1]) else top * 0.5
		loft.add(centre, Vector3(station[1], 0, 0), Vector3(0, height, 0), _blend(bones, joints, z))
	body.add_loft(loft)


# A tube along the joint chain `points`: each station is [segment, fraction
# along it (beyond 0..1 past the ends), half-width, half-depth, forward
# shift]; weights blend along the chain's length at `joints`.
static func _chain(
	points: PackedVector3Array,
	bones: PackedInt32Array,
	joints: PackedVector2Array,
	stations: Array,
	forward: Vector3,
	mirror: float
) -> _Loft:
	var loft := _Loft.new(SIDES, 2.0)
	var starts := PackedFloat32Array([0.0])
	for i in points.size() - 1:
		starts.append(starts[i] + points[i].distance_to(points[i + 1]))
	for station: Array in stations:
		var segment: int = station[0]
		var t: float = station[1]
		var axis := (points[segment + 1] - points[segment]).normalized()
		var front := (forward - axis * forward.dot(axis)).normalized()
		var side := axis.cross(front) * mirror
		var centre := points[segment].lerp(points[segment + 1], t) + front * (station[4] as float)
		var s := starts[segment] + t * (starts[segment + 1] - starts[segment])
		loft.add(
			centre,
			side * (station[2] as float),
			front * (station[3] as float),
			_blend(bones, joints, s)
		)
	return loft


## Rings of a lofted tube: superellipse cross-sections (centre, half-axes u
## and v, bone weights); a ring with zero axes is a pole that closes the end.
class _Loft:
	var sides: int
	var exponent: float
	var centres := PackedVector3Array()
	var us := PackedVector3Array()
	var vs := PackedVector3Array()
	var weights: Array[Dictionary] = []
	## Optional per-vertex weights: func(position, ring_weights) -> weights.
	var adjust := Callable()

	func _init(side_count: int, superellipse: float) -> void:
		sides = side_count
		exponent = superellipse

	func add(centre: Vector3, u: Vector3, v: Vector3, ring_weights: Dictionary) -> void:
		centres.append(centre)
		us.append(u)
		vs.append(v)
		weights.append(ring_weights)


## Vertex, weight and index arrays of one surface; normals are averaged
## from the faces when the arrays are taken.
class _MeshData:
	var positions := PackedVector3Array()
	var bones := PackedInt32Array()
	var weights := PackedFloat32Array()
	var indices := PackedInt32Array()

	func add_loft(loft: _Loft) -> void:
		var cosines := PackedFloat32Array()
		var sines := PackedFloat32Array()
		var power := 2.0 / loft.exponent
		for j in loft.sides:
			var angle := TAU * j / loft.sides
			var c := cos(angle)
			var s := sin(angle)
			cosines.append(signf(c) * pow(absf(c), power))
			sines.append(signf(s) * pow(absf(s), power))
		var rings: Array[PackedInt32Array] = []
		for k in loft.centres.size():
			var ring := PackedInt32Array()
			var centre := loft.centres[k]
			var pole := loft.us[k].is_zero_approx() or loft.vs[k].is_zero_approx()
			for j in 1 if pole else loft.sides:
				var p := (
					centre if pole else centre + loft.us[k] * cosines[j] + loft.vs[k] * sines[j]
				)
				var w: Dictionary = loft.weights[k]
				if loft.adjust.is_valid():
					w = loft.adjust.call(p, w)
				ring.append(_vertex(p, w))
			rings.append(ring)
		# Wind the faces so that they face outwards (Godot: clockwise).
		var flip := loft.us[1].cross(loft.vs[1]).dot(loft.centres[1] - loft.centres[0]) > 0.0
		for k in rings.size() - 1:
			for j in loft.sides:
				var a := rings[k][j % rings[k].size()]
				var b := rings[k][(j + 1) % loft.sides % rings[k].size()]
				var c := rings[k + 1][j % rings[k + 1].size()]
				var d := rings[k + 1][(j + 1) % loft.sides % rings[k + 1].size()]
				_triangle(a, b, c, flip)
				_triangle(b, d, c, flip)

	func _vertex(p: Vector3, w: Dictionary) -> int:
		positions.append(p)
		var order := w.keys()
		order.sort_custom(func(x: int, y: int) -> bool: return w[x] > w[y])
		var total := 0.0
		for i in mini(4, order.size()):
			total += w[order[i]]
		for i in 4:
			var has := i < order.size()
			bones.append(order[i] if has else 0)
			weights.append(w[order[i]] / total if has else 0.0)
		return positions.size() - 1

	func _triangle(a: int, b: int, c: int, flip: bool) -> void:
		if a == b or b == c or a == c:
			return
		if flip:
			indices.append_array([a, c, b])
		else:
			indices.append_array([a, b, c])

	func arrays() -> Array:
		var normals := PackedVector3Array()
		normals.resize(positions.size())
		for i in range(0, indices.size(), 3):
			var a := positions[indices[i]]
			# Clockwise front faces: this cross product points out of them.
			var n := (positions[indices[i + 2]] - a).cross(positions[indices[i + 1]] - a)
			normals[indices[i]] += n
			normals[indices[i + 1]] += n
			normals[indices[i + 2]] += n
		for i in normals.size():
			normals[i] = normals[i].normalized()
		var result := []
		result.resize(Mesh.ARRAY_MAX)
		result[Mesh.ARRAY_VERTEX] = positions
		result[Mesh.ARRAY_NORMAL] = normals
		result[Mesh.ARRAY_BONES] = bones
		result[Mesh.ARRAY_WEIGHTS] = weights
		result[Mesh.ARRAY_INDEX] = indices
		return result
