class_name TestCharacter
extends RefCounted
## One generated character for the engine tests: a rig, its MotionGenerator
## and the bone positions it showed, recorded in world space every time the
## skeleton finished its update (after the generator's pose modifier ran).

const MODEL := "res://addons/ardy/models/default"

var root: Node3D
var skeleton: Skeleton3D
var generator: MotionGenerator
## One entry per skeleton update: {"time": motion clock, "bones": {name: Vector3},
## "rotations": {name: world Quaternion}, "hips_basis": the root bone's basis in
## the skeleton}.
var samples: Array[Dictionary] = []
var watched: PackedStringArray = ["Hips", "Hand_R", "UpperArm_R", "Head"]
## Off for tests that measure memory: the samples grow with every frame.
var recording := true


func _init(rig: Skeleton3D = null, parent: Node = null) -> void:
	root = Node3D.new()
	root.name = "Character"
	skeleton = rig if rig != null else TestRigs.model_rig(MODEL)
	root.add_child(skeleton)
	generator = MotionGenerator.new()
	generator.name = "MotionGenerator"
	root.add_child(generator)
	generator.skeleton = NodePath("../" + skeleton.name)
	skeleton.skeleton_updated.connect(_record)
	if parent != null:
		parent.add_child(root)


func _record() -> void:
	if not recording:
		return
	var bones := {}
	var rotations := {}
	for bone_name in watched:
		var bone := skeleton.find_bone(bone_name)
		if bone >= 0:
			var pose := skeleton.global_transform * skeleton.get_bone_global_pose(bone)
			bones[bone_name] = pose.origin
			rotations[bone_name] = pose.basis.get_rotation_quaternion()
	(
		samples
		. append(
			{
				"time": generator.get_time(),
				"bones": bones,
				"rotations": rotations,
				"hips_basis": skeleton.get_bone_global_pose(0).basis,
			}
		)
	)


## Waits (real frames) until the model is loaded and generation has started.
func wait_until_generating(tree: SceneTree, timeout_seconds := 60.0) -> bool:
	var deadline := Time.get_ticks_msec() + int(timeout_seconds * 1000.0)
	while not generator.is_generating() and Time.get_ticks_msec() < deadline:
		await tree.process_frame
	return generator.is_generating()


## Waits until the motion clock reaches `seconds` (or a real-time timeout).
func wait_until_time(tree: SceneTree, seconds: float, timeout_seconds := 60.0) -> bool:
	var deadline := Time.get_ticks_msec() + int(timeout_seconds * 1000.0)
	while generator.get_time() < seconds and Time.get_ticks_msec() < deadline:
		await tree.process_frame
	return generator.get_time() >= seconds


## The world position of a watched bone at the last sample at or before `seconds`.
func position_at(bone_name: String, seconds: float) -> Vector3:
	var found: Variant = _sampled_at("bones", bone_name, seconds)
	return found if found != null else Vector3.INF


## The world rotation of a watched bone at the last sample at or before `seconds`.
func rotation_at(bone_name: String, seconds: float) -> Quaternion:
	var found: Variant = _sampled_at("rotations", bone_name, seconds)
	return found if found != null else Quaternion.IDENTITY


## A sample field's value for `bone_name` at the last sample at or before `seconds` (null if none).
func _sampled_at(field: String, bone_name: String, seconds: float) -> Variant:
	var found: Variant = null
	for sample in samples:
		if sample["time"] <= seconds and sample[field].has(bone_name):
			found = sample[field][bone_name]
	return found


func last_position(bone_name: String) -> Vector3:
	return samples.back()["bones"][bone_name] if not samples.is_empty() else Vector3.INF


## Records every bone of the rig (the hips' world basis is in every sample).
func watch_every_bone() -> void:
	var names: PackedStringArray = []
	for bone in skeleton.get_bone_count():
		names.append(skeleton.get_bone_name(bone))
	watched = names


## The mean distance, over every bone, between the body's shape in the last
## sample at or before `seconds` and the shape of `pose` (bone name -> local
## rotation) on a copy of the model's rig.
func pose_error(pose: Dictionary, seconds: float) -> float:
	var copy := TestRigs.model_rig(MODEL)
	for bone_name: String in pose:
		copy.set_bone_pose_rotation(copy.find_bone(bone_name), pose[bone_name])
	var wanted := {}
	for bone in copy.get_bone_count():
		wanted[copy.get_bone_name(bone)] = copy.get_bone_global_pose(bone).origin
	copy.free()
	var wanted_shape := body_shape(wanted, Basis())
	var shown := {}
	for sample in samples:
		if sample["time"] <= seconds:
			shown = body_shape(sample["bones"], sample["hips_basis"])
	var total := 0.0
	for bone_name: String in wanted_shape:
		total += (shown[bone_name] - wanted_shape[bone_name]).length()
	return total / wanted_shape.size()


## Bone positions relative to the hips, turned so the hips face +Z: the
## body's shape wherever it stands and whichever way it faces.
static func body_shape(bones: Dictionary, hips_basis: Basis) -> Dictionary:
	var forward := hips_basis * Vector3(0, 0, 1)
	var unturn := Basis(Vector3.UP, -atan2(forward.x, forward.z))
	var shape := {}
	for bone_name in bones:
		shape[bone_name] = unturn * (bones[bone_name] - bones["Hips"])
	return shape


func dispose() -> void:
	root.free()
