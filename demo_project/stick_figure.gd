class_name StickFigure
extends RefCounted
## A rig with the model's own joints (read from the package's model.json) and
## a capsule along each bone, so the generated motion can be seen before the
## demo's real character exists.


static func build(model_path: String) -> Skeleton3D:
	var parsed: Dictionary = JSON.parse_string(
		FileAccess.get_file_as_string(model_path.path_join("model.json"))
	)
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
	var material := StandardMaterial3D.new()
	material.albedo_color = Color(0.85, 0.55, 0.3)
	for i in joints.size():
		var parent: int = data["parents"][i]
		if parent < 0:
			continue
		var offset: Array = data["rest_offsets"][i]
		var bone := Vector3(offset[0], offset[1], offset[2])
		if bone.length() < 0.02:
			continue
		var attachment := BoneAttachment3D.new()
		attachment.bone_name = joints[parent]
		skeleton.add_child(attachment)
		var capsule := CapsuleMesh.new()
		capsule.radius = 0.045
		capsule.height = bone.length() + 0.09
		capsule.material = material
		var mesh := MeshInstance3D.new()
		mesh.mesh = capsule
		# The capsule's axis is +Y: turn it onto the bone, centred on it.
		var basis := Basis(Quaternion(Vector3.UP, bone.normalized()))
		mesh.transform = Transform3D(basis, bone * 0.5)
		attachment.add_child(mesh)
	return skeleton
