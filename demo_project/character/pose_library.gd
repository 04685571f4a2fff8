class_name PoseLibrary
extends RefCounted
## Named full-body poses for a humanoid rig with SkeletonProfileHumanoid bone
## names, made by aiming bones along directions in skeleton space (the
## character faces +Z, its left side is +X), so they fit any rest pose.

## Bone -> direction, applied in order (parents before children).
const POSES := {
	"hands up":
	[
		["LeftUpperArm", Vector3(0.25, 1, 0)],
		["LeftLowerArm", Vector3(0.1, 1, 0)],
		["RightUpperArm", Vector3(-0.25, 1, 0)],
		["RightLowerArm", Vector3(-0.1, 1, 0)],
	],
	"t-pose":
	[
		["LeftUpperArm", Vector3(1, 0, 0)],
		["LeftLowerArm", Vector3(1, 0, 0)],
		["RightUpperArm", Vector3(-1, 0, 0)],
		["RightLowerArm", Vector3(-1, 0, 0)],
		["LeftUpperLeg", Vector3(0, -1, 0)],
		["RightUpperLeg", Vector3(0, -1, 0)],
	],
	"crouch":
	[
		["Spine", Vector3(0, 1, 0.45)],
		["LeftUpperLeg", Vector3(0.15, -0.55, 0.85)],
		["LeftLowerLeg", Vector3(0.05, -1, -0.35)],
		["LeftFoot", Vector3(0, -0.35, 1)],
		["RightUpperLeg", Vector3(-0.15, -0.55, 0.85)],
		["RightLowerLeg", Vector3(-0.05, -1, -0.35)],
		["RightFoot", Vector3(0, -0.35, 1)],
		["LeftUpperArm", Vector3(0.2, -0.3, 1)],
		["LeftLowerArm", Vector3(0.05, 0, 1)],
		["RightUpperArm", Vector3(-0.2, -0.3, 1)],
		["RightLowerArm", Vector3(-0.05, 0, 1)],
	],
}


## Puts `skeleton` in the named pose, its lowest bone as high as in its rest
## pose (a crouch lowers the hips rather than lifting the feet).
static func apply(skeleton: Skeleton3D, pose_name: String) -> void:
	skeleton.reset_bone_poses()
	var rest_lowest := _lowest_bone_height(skeleton)
	for entry: Array in POSES[pose_name]:
		_aim(skeleton, skeleton.find_bone(entry[0]), entry[1])
	var root := skeleton.find_bone("Hips")
	var drop := _lowest_bone_height(skeleton) - rest_lowest
	skeleton.set_bone_pose_position(
		root, skeleton.get_bone_pose_position(root) - Vector3(0, drop, 0)
	)


## Turns `bone` so the direction to its first child points along `direction`
## (skeleton space), its parents' poses as they are.
static func _aim(skeleton: Skeleton3D, bone: int, direction: Vector3) -> void:
	var parent := skeleton.get_bone_parent(bone)
	var parent_basis := _global_pose(skeleton, parent).basis if parent >= 0 else Basis()
	var pose_basis := parent_basis * Basis(skeleton.get_bone_pose_rotation(bone))
	var child: int = skeleton.get_bone_children(bone)[0]
	var pointing := (pose_basis * skeleton.get_bone_rest(child).origin).normalized()
	var aimed := Basis(Quaternion(pointing, direction.normalized())) * pose_basis
	var local := (parent_basis.inverse() * aimed).get_rotation_quaternion()
	skeleton.set_bone_pose_rotation(bone, local)


static func _lowest_bone_height(skeleton: Skeleton3D) -> float:
	var lowest := INF
	for bone in skeleton.get_bone_count():
		lowest = minf(lowest, _global_pose(skeleton, bone).origin.y)
	return lowest


# The bone's pose in skeleton space from the poses set so far. Computed here:
# Skeleton3D.get_bone_global_pose misses poses set after it was last read
# within a frame.
static func _global_pose(skeleton: Skeleton3D, bone: int) -> Transform3D:
	var local := Transform3D(
		Basis(skeleton.get_bone_pose_rotation(bone)), skeleton.get_bone_pose_position(bone)
	)
	var parent := skeleton.get_bone_parent(bone)
	return _global_pose(skeleton, parent) * local if parent >= 0 else local
