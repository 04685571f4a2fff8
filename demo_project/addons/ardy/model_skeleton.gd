class_name ArdyModelSkeleton
extends RefCounted
## A Skeleton3D with a model package's own joints: the names, parents and
## rest offsets of its model.json, with identity rest rotations. Useful to
## look at a model's raw motion, and as a reference rig in tests.


static func build(model_path: String) -> Skeleton3D:
	var text := FileAccess.get_file_as_string(model_path.path_join("model.json"))
	var parsed: Dictionary = JSON.parse_string(text)
	var data: Dictionary = parsed["skeleton"]
	var joints: Array = data["joints"]
	var skeleton := Skeleton3D.new()
	skeleton.name = "Skeleton3D"
	for i in joints.size():
		skeleton.add_bone(joints[i])
		var parent: int = data["parents"][i]
		if parent >= 0:
			skeleton.set_bone_parent(i, parent)
		var offset: Array = data["rest_offsets"][i]
		skeleton.set_bone_rest(i, Transform3D(Basis(), Vector3(offset[0], offset[1], offset[2])))
	skeleton.reset_bone_poses()
	return skeleton
