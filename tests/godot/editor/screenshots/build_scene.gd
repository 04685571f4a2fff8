extends SceneTree
## Saves res://authoring_example.tscn for the editor screenshots
## (scripts/editor_screenshots.sh runs it headless in a copy of the demo
## project): the demo's stage, a mannequin and a MotionGenerator on it with a
## MotionTimeline of prompts, three waypoints, a path, a keyframe, a joint
## target and a contact.

const SCENE_PATH := "res://authoring_example.tscn"
## Where the 3D editor camera looks at and from (world space), kept as the
## scene's editor state, which the editor restores when it opens the scene.
const CAMERA_AT := Vector3(1.6, 0.6, 1.1)
const CAMERA_FROM := Vector3(-0.4, 2.85, 4.5)


func _initialize() -> void:
	var root := Node3D.new()
	root.name = "AuthoringExample"
	var stage: Node3D = (load("res://world/stage.tscn") as PackedScene).instantiate()
	stage.name = "Stage"
	root.add_child(stage)
	var character := Node3D.new()
	character.name = "Character"
	root.add_child(character)
	var skeleton: Skeleton3D = Mannequin.build()
	character.add_child(skeleton)
	var generator := MotionGenerator.new()
	generator.name = "MotionGenerator"
	generator.skeleton = NodePath("../Skeleton3D")
	generator.timeline = _timeline(skeleton)
	character.add_child(generator)
	_own(root, root)
	var scene := PackedScene.new()
	var error: Error = scene.pack(root)
	if error == OK:
		error = ResourceSaver.save(scene, SCENE_PATH)
	print("build_scene: saved %s (%s)" % [SCENE_PATH, error_string(error)])
	root.free()
	if error == OK:
		error = _save_camera()
	quit(0 if error == OK else 1)


# The editor's per-scene state file (.godot/editor/<file>-editstate-<md5 of
# the path>.cfg) with the 3D viewport's orbit: it looks at `position` from
# `distance` away, pitched down by x_rotation, turned by y_rotation.
func _save_camera() -> Error:
	var offset: Vector3 = CAMERA_FROM - CAMERA_AT
	var distance: float = offset.length()
	var x_rotation: float = asin(offset.y / distance)
	var y_rotation: float = atan2(-offset.x, offset.z)
	var viewport := {
		"position": CAMERA_AT,
		"x_rotation": x_rotation,
		"y_rotation": y_rotation,
		"distance": distance,
		"orthogonal": false,
	}
	var state := ConfigFile.new()
	state.set_value("editor_states", "3D", {"viewports": [viewport]})
	var folder: String = "res://.godot/editor"
	DirAccess.make_dir_recursive_absolute(folder)
	var path: String = folder.path_join(
		"%s-editstate-%s.cfg" % [SCENE_PATH.get_file(), SCENE_PATH.md5_text()]
	)
	var error: Error = state.save(path)
	print("build_scene: saved %s (%s)" % [path, error_string(error)])
	return error


func _timeline(skeleton: Skeleton3D) -> MotionTimeline:
	var timeline := MotionTimeline.new()
	timeline.length = 10.0
	var prompts: Array[MotionPrompt] = [
		_prompt(0.0, "a person walks forward"),
		_prompt(4.0, "a person waves with the right hand"),
		_prompt(7.0, "a person walks in a circle"),
	]
	timeline.prompts = prompts
	var waypoints: Array[MotionWaypoint] = [
		_waypoint(1.5, Vector3(0.0, 0.0, 1.8), false, 0.0),
		_waypoint(3.5, Vector3(1.5, 0.0, 3.0), true, PI * 0.5),
		_waypoint(6.0, Vector3(3.0, 0.0, 1.5), true, PI),
	]
	timeline.waypoints = waypoints
	var path := MotionPath.new()
	path.start_time = 7.0
	path.speed = 1.2
	path.points = PackedVector3Array(
		[Vector3(3.0, 0.0, 1.5), Vector3(3.6, 0.0, 0.0), Vector3(2.6, 0.0, -1.2)]
	)
	var paths: Array[MotionPath] = [path]
	timeline.paths = paths
	var keyframe := MotionKeyframe.new()
	keyframe.time = 5.0
	keyframe.pose = _raised_arms(skeleton)
	var keyframes: Array[MotionKeyframe] = [keyframe]
	timeline.keyframes = keyframes
	var target := MotionJointTarget.new()
	target.time = 3.0
	target.bone = "RightHand"
	target.use_position = true
	target.position = Vector3(0.5, 1.6, 2.7)
	var targets: Array[MotionJointTarget] = [target]
	timeline.joint_targets = targets
	var contact := MotionContact.new()
	contact.start_time = 8.0
	contact.end_time = 9.0
	contact.feet = 0
	contact.planted = true
	var contacts: Array[MotionContact] = [contact]
	timeline.contacts = contacts
	return timeline


# Local rotations that lift both upper arms over the head (a "hands up").
func _raised_arms(skeleton: Skeleton3D) -> Dictionary:
	var pose := {}
	for side: String in ["Left", "Right"]:
		var bone: int = skeleton.find_bone(side + "UpperArm")
		var rest: Quaternion = skeleton.get_bone_rest(bone).basis.get_rotation_quaternion()
		var sign_x: float = 1.0 if side == "Left" else -1.0
		# Turn about the bone's forward axis (+Z, the body's front) by ~110 deg.
		var lift := Quaternion(Vector3(0, 0, 1), sign_x * deg_to_rad(110.0))
		pose[side + "UpperArm"] = rest * lift
	return pose


func _prompt(time: float, text: String) -> MotionPrompt:
	var prompt := MotionPrompt.new()
	prompt.time = time
	prompt.text = text
	return prompt


func _waypoint(time: float, position: Vector3, use_heading: bool, heading: float) -> MotionWaypoint:
	var waypoint := MotionWaypoint.new()
	waypoint.time = time
	waypoint.position = position
	waypoint.use_heading = use_heading
	waypoint.heading = heading
	return waypoint


func _own(node: Node, owner_node: Node) -> void:
	for child: Node in node.get_children():
		child.owner = owner_node
		# The stage stays an instance: its inner nodes keep their own owner.
		if child.scene_file_path.is_empty():
			_own(child, owner_node)
