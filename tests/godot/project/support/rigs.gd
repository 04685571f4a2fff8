class_name TestRigs
extends RefCounted
## Rigs the engine tests drive: the model's own skeleton read from its
## model.json, and humanoid rigs with other names, proportions and rest poses.

const HUMANOID_NAMES := {
	"Hips": "Hips",
	"Spine": "Spine",
	"Chest": "Chest",
	"Neck": "Neck",
	"Head": "Head",
	"Shoulder_L": "LeftShoulder",
	"UpperArm_L": "LeftUpperArm",
	"LowerArm_L": "LeftLowerArm",
	"Hand_L": "LeftHand",
	"Shoulder_R": "RightShoulder",
	"UpperArm_R": "RightUpperArm",
	"LowerArm_R": "RightLowerArm",
	"Hand_R": "RightHand",
	"UpperLeg_L": "LeftUpperLeg",
	"LowerLeg_L": "LeftLowerLeg",
	"Foot_L": "LeftFoot",
	"Toes_L": "LeftToes",
	"UpperLeg_R": "RightUpperLeg",
	"LowerLeg_R": "RightLowerLeg",
	"Foot_R": "RightFoot",
	"Toes_R": "RightToes",
}


## The skeleton section of a model package's model.json.
static func model_skeleton(model_path: String) -> Dictionary:
	var text := FileAccess.get_file_as_string(model_path.path_join("model.json"))
	var parsed: Dictionary = JSON.parse_string(text)
	return parsed["skeleton"]


## A Skeleton3D with the model's joint names and rest offsets (identity rests).
static func model_rig(model_path: String) -> Skeleton3D:
	return ArdyModelSkeleton.build(model_path)


## A humanoid rig with SkeletonProfileHumanoid names, the model's shape
## scaled by `scale`, an UpperChest between Chest and Neck, a finger, and a
## rest rotation of `twist` radians about a different axis on every bone
## (children's offsets expressed in the rotated frames, so the rest pose in
## space is the model's, scaled).
static func humanoid_rig(model_path: String, scale: float, twist: float) -> Skeleton3D:
	var skeleton_data := model_skeleton(model_path)
	var joints: Array = skeleton_data["joints"]
	var positions: Array[Vector3] = []
	var frames: Array[Basis] = []
	for i in joints.size():
		var offset: Array = skeleton_data["rest_offsets"][i]
		var parent: int = skeleton_data["parents"][i]
		var local := Vector3(offset[0], offset[1], offset[2]) * scale
		positions.append(local if parent < 0 else positions[parent] + local)
		var axis := Vector3(sin(i * 1.7), cos(i * 0.9), sin(i * 0.4 + 1.0)).normalized()
		frames.append(Basis(axis, twist))
	positions[0] = Vector3(0, 0.0, 0)
	var skeleton := Skeleton3D.new()
	skeleton.name = "Skeleton3D"
	var index := {}
	for i in joints.size():
		var bone_name: String = HUMANOID_NAMES[joints[i]]
		var parent: int = skeleton_data["parents"][i]
		if joints[i] == "Neck" or joints[i] == "Shoulder_L" or joints[i] == "Shoulder_R":
			if not index.has("UpperChest"):
				_add(
					skeleton,
					index,
					"UpperChest",
					index["Chest"],
					frames[2],
					positions[2],
					frames[2],
					positions[2]
				)
			var upper: int = index["UpperChest"]
			_add(
				skeleton, index, bone_name, upper, frames[2], positions[2], frames[i], positions[i]
			)
			continue
		var parent_frame := Basis() if parent < 0 else frames[parent]
		var parent_position := Vector3.ZERO if parent < 0 else positions[parent]
		var parent_index: int = -1 if parent < 0 else index[HUMANOID_NAMES[joints[parent]]]
		_add(
			skeleton,
			index,
			bone_name,
			parent_index,
			parent_frame,
			parent_position,
			frames[i],
			positions[i]
		)
	var hand: int = index["LeftHand"]
	_add(
		skeleton,
		index,
		"LeftIndexProximal",
		hand,
		frames[8],
		positions[8],
		frames[8],
		positions[8] + Vector3(0.05, 0, 0)
	)
	skeleton.reset_bone_poses()
	return skeleton


static func _add(
	skeleton: Skeleton3D,
	index: Dictionary,
	bone_name: String,
	parent: int,
	parent_frame: Basis,
	parent_position: Vector3,
	frame: Basis,
	position: Vector3
) -> void:
	var bone := skeleton.get_bone_count()
	skeleton.add_bone(bone_name)
	index[bone_name] = bone
	if parent >= 0:
		skeleton.set_bone_parent(bone, parent)
	var rest := Transform3D(
		parent_frame.inverse() * frame, parent_frame.inverse() * (position - parent_position)
	)
	skeleton.set_bone_rest(bone, rest)
