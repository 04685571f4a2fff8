class_name StickFigure
extends RefCounted
## The model's own rig (ArdyModelSkeleton) with a capsule along each bone, so
## the generated motion can be seen before the demo's real character exists.


static func build(model_path: String) -> Skeleton3D:
	var skeleton := ArdyModelSkeleton.build(model_path)
	var material := StandardMaterial3D.new()
	material.albedo_color = Color(0.85, 0.55, 0.3)
	for i in skeleton.get_bone_count():
		var parent := skeleton.get_bone_parent(i)
		var bone := skeleton.get_bone_rest(i).origin
		if parent < 0 or bone.length() < 0.02:
			continue
		var attachment := BoneAttachment3D.new()
		attachment.bone_name = skeleton.get_bone_name(parent)
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
