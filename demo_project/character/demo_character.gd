class_name DemoCharacter
extends Node3D
## What the demo's scenes put on the stage: a mannequin on its own rig driven
## by a MotionGenerator with the shipped model (through its retargeting).

var skeleton: Skeleton3D
var generator: MotionGenerator
## The shown hips in world space (INF before the first generated pose).
var hips := Vector3.INF


func _init() -> void:
	skeleton = Mannequin.build()
	add_child(skeleton)
	# Generated poses exist only in the skeleton's update (modifiers are not
	# kept in the bone poses): read the hips there.
	var hips_bone := skeleton.find_bone("Hips")
	skeleton.skeleton_updated.connect(
		func() -> void:
			if generator.is_generating():
				hips = skeleton.global_transform * skeleton.get_bone_global_pose(hips_bone).origin
	)
	generator = MotionGenerator.new()
	generator.name = "MotionGenerator"
	generator.skeleton = NodePath("../Skeleton3D")
	generator.playing = true
	add_child(generator)
