extends TestCase
## MotionTimeline: saved and loaded as a resource, played live by a
## MotionGenerator, generated ahead of time as a clip, baked into an Animation
## an AnimationPlayer replays, and converted to the JSON timeline that
## ardy-generate (the CLI, named by $ARDY_CLI) turns into the same motion.

const SEED := 7
## Both upper arms raised 70 degrees, forearms bent up.
const HANDS_UP := {
	"UpperArm_L": Quaternion(Vector3(0, 0, 1), 1.2217305),
	"UpperArm_R": Quaternion(Vector3(0, 0, 1), -1.2217305),
	"LowerArm_L": Quaternion(Vector3(0, 0, 1), 0.34906585),
	"LowerArm_R": Quaternion(Vector3(0, 0, 1), -0.34906585),
}


func _prompt(time: float, text: String) -> MotionPrompt:
	var prompt := MotionPrompt.new()
	prompt.time = time
	prompt.text = text
	return prompt


func _waypoint(time: float, position: Vector3) -> MotionWaypoint:
	var waypoint := MotionWaypoint.new()
	waypoint.time = time
	waypoint.position = position
	return waypoint


func _keyframe(time: float, pose: Dictionary) -> MotionKeyframe:
	var keyframe := MotionKeyframe.new()
	keyframe.time = time
	keyframe.pose = pose
	return keyframe


## Walk 3 m to a waypoint at 3 s, then stand and raise both hands at 5.5 s.
func _walk_then_hands_up() -> MotionTimeline:
	var timeline := MotionTimeline.new()
	timeline.length = 6.0
	timeline.prompts = [_prompt(0.0, "walk forward"), _prompt(3.5, "stand still")]
	timeline.waypoints = [_waypoint(3.0, Vector3(0.5, 0.0, 3.0))]
	timeline.keyframes = [_keyframe(5.5, HANDS_UP)]
	return timeline


func _every_track() -> MotionTimeline:
	var timeline := _walk_then_hands_up()
	timeline.loop = true
	var path := MotionPath.new()
	path.start_time = 6.0
	path.speed = 1.5
	path.points = PackedVector3Array([Vector3(0, 0, 3), Vector3(2, 0, 4), Vector3(3, 0, 6)])
	timeline.paths = [path]
	var target := MotionJointTarget.new()
	target.time = 8.0
	target.bone = "Hand_R"
	target.position = Vector3(0.3, 1.4, 5.0)
	target.use_rotation = true
	target.rotation = Quaternion(Vector3.UP, 0.5)
	timeline.joint_targets = [target]
	var contact := MotionContact.new()
	contact.start_time = 1.0
	contact.end_time = 1.5
	contact.feet = 1
	contact.planted = false
	timeline.contacts = [contact]
	var heading_waypoint := _waypoint(9.0, Vector3(3, 0, 6))
	heading_waypoint.use_heading = true
	heading_waypoint.heading = 1.0
	timeline.waypoints = timeline.waypoints + [heading_waypoint]
	return timeline


## The property values of every item of every track, in order.
func _describe(timeline: MotionTimeline) -> Array:
	var tracks := [
		timeline.prompts,
		timeline.waypoints,
		timeline.paths,
		timeline.keyframes,
		timeline.joint_targets,
		timeline.contacts
	]
	var described: Array = [timeline.length, timeline.loop]
	for track: Array in tracks:
		for item: Resource in track:
			var values := [item.get_class()]
			for property in item.get_property_list():
				if (
					property["usage"] & PROPERTY_USAGE_STORAGE
					and property["name"] != "resource_path"
				):
					values.append([property["name"], item.get(property["name"])])
			described.append(values)
	return described


func _start(timeline: MotionTimeline) -> TestCharacter:
	var character := TestCharacter.new(null, tree.root)
	character.generator.seed = SEED
	character.generator.timeline = timeline
	return character


func test_a_saved_timeline_loads_back_with_every_track() -> void:
	var timeline := _every_track()
	var path := "user://timeline_round_trip.tres"
	check_eq(ResourceSaver.save(timeline, path), OK, "the timeline was saved")
	var loaded: MotionTimeline = ResourceLoader.load(path, "", ResourceLoader.CACHE_MODE_IGNORE)
	check(loaded != null and loaded != timeline, "a new MotionTimeline was loaded")
	check_eq(loaded.get_waypoints().size(), 2, "two waypoints came back")
	check_eq(_describe(loaded), _describe(timeline), "every track and item property")
	DirAccess.remove_absolute(ProjectSettings.globalize_path(path))


func test_playing_a_timeline_reaches_its_waypoint_and_keyframe() -> void:
	var character := _start(_walk_then_hands_up())
	var generator := character.generator
	character.watch_every_bone()
	var finished := [false]
	generator.timeline_finished.connect(func() -> void: finished[0] = true)
	generator.playing = true
	check(await character.wait_until_generating(tree), "generating: " + generator.get_last_error())
	check(await character.wait_until_time(tree, 6.1), "the clock passed the timeline's end")
	var hips := character.position_at("Hips", 3.0)
	var miss := Vector2(hips.x - 0.5, hips.z - 3.0).length()
	print("  timeline waypoint at 3 s: missed by %.3f m" % miss)
	check(miss <= 0.3, "the waypoint was missed by %.3f m, expected at most 0.3 m" % miss)

	var mean := character.pose_error(HANDS_UP, 5.5)
	print("  timeline keyframe at 5.5 s: mean joint error %.3f m" % mean)
	check(mean <= 0.15, "mean joint error %.3f m at the keyframe, expected at most 0.15 m" % mean)
	check(finished[0], "timeline_finished was emitted")
	character.dispose()


## World transforms of every bone a few frames on. A modifier's pose is seen
## only in the skeleton's update (the skeleton restores its own poses after
## it); an AnimationPlayer's poses stay.
func _bone_poses(skeleton: Skeleton3D, modified: bool) -> Array[Transform3D]:
	for frame in 2:
		await (skeleton.skeleton_updated if modified else tree.process_frame)
	var poses: Array[Transform3D] = []
	for bone in skeleton.get_bone_count():
		poses.append(skeleton.global_transform * skeleton.get_bone_global_pose(bone))
	return poses


## The worst bone's distance (x, metres) and turn (y, degrees) between two poses.
func _pose_difference(a: Array[Transform3D], b: Array[Transform3D]) -> Vector2:
	var worst := Vector2.ZERO
	for bone in a.size():
		var turn := a[bone].basis.get_rotation_quaternion().angle_to(
			b[bone].basis.get_rotation_quaternion()
		)
		worst = worst.max(Vector2(a[bone].origin.distance_to(b[bone].origin), rad_to_deg(turn)))
	return worst


func test_a_baked_animation_replays_the_generated_pose() -> void:
	var character := _start(_walk_then_hands_up())
	var generator := character.generator
	var animation: Animation = generator.bake_animation(4.0, 30.0)
	check(animation != null, "baked: " + generator.get_last_error())
	check(absf(animation.length - 4.0) < 1e-4, "length %.3f s" % animation.length)
	var bones := character.skeleton.get_bone_count()
	# Every bone of the model's own rig is driven, plus the hips' position.
	check_eq(animation.get_track_count(), bones + 1, "tracks")

	var player_root := Node3D.new()
	player_root.name = "Replay"
	var replay := TestRigs.model_rig(TestCharacter.MODEL)
	replay.name = character.skeleton.name
	player_root.add_child(replay)
	var player := AnimationPlayer.new()
	player_root.add_child(player)
	tree.root.add_child(player_root)
	var library := AnimationLibrary.new()
	library.add_animation("motion", animation)
	player.add_animation_library("", library)
	player.play("motion")
	player.pause()

	# On the keys (multiples of 1/30 s) the replay is the generated pose.
	var on_keys := Vector2.ZERO  # worst metres, worst degrees
	for time: float in [0.0, 1.9, 3.3, 3.9]:
		generator.seek_clip(time)
		var generated := await _bone_poses(character.skeleton, true)
		player.seek(time, true)
		on_keys = on_keys.max(_pose_difference(generated, await _bone_poses(replay, false)))
	print("  bake: on the keys, worst bone %.4f m, %.3f deg off" % [on_keys.x, on_keys.y])
	check(on_keys.x <= 0.001, "a bone is %.4f m off on a key, expected at most 1 mm" % on_keys.x)
	check(on_keys.y <= 0.1, "a bone is %.3f deg off on a key, expected at most 0.1" % on_keys.y)

	# Between two keys the player interpolates them: off by less than the generated
	# motion moves in that key step.
	var between := 0.75
	var poses_at := {}
	for time: float in [between, 22.0 / 30.0, 23.0 / 30.0]:
		generator.seek_clip(time)
		poses_at[time] = await _bone_poses(character.skeleton, true)
	player.seek(between, true)
	var off := _pose_difference(poses_at[between], await _bone_poses(replay, false))
	var step := _pose_difference(poses_at[22.0 / 30.0], poses_at[23.0 / 30.0])
	print(
		(
			"  bake: between keys, worst bone %.4f m, %.3f deg off (one key step: %.4f m, %.3f deg)"
			% [off.x, off.y, step.x, step.y]
		)
	)
	check(off.x < step.x, "between keys %.4f m off, one key step moves %.4f m" % [off.x, step.x])
	check(off.y < step.y, "between keys %.3f deg off, one key step turns %.3f" % [off.y, step.y])
	player_root.free()
	character.dispose()


## The frame lines of a BVH file as rows of numbers.
func _bvh_frames(path: String) -> Array[PackedFloat64Array]:
	var rows: Array[PackedFloat64Array] = []
	var in_motion := false
	for line in FileAccess.get_file_as_string(path).split("\n"):
		if line.begins_with("Frame Time:"):
			in_motion = true
		elif in_motion and not line.strip_edges().is_empty():
			rows.append(line.split_floats(" "))
	return rows


func test_the_json_timeline_gives_the_cli_the_same_motion() -> void:
	var cli := OS.get_environment("ARDY_CLI")
	check(FileAccess.file_exists(cli), "ARDY_CLI names the ardy-generate binary (found '%s')" % cli)
	var character := _start(_walk_then_hands_up())
	var generator := character.generator
	var node_bvh := ProjectSettings.globalize_path("user://timeline_node.bvh")
	var cli_bvh := ProjectSettings.globalize_path("user://timeline_cli.bvh")
	var json_path := ProjectSettings.globalize_path("user://timeline.json")
	check_eq(generator.export_bvh(node_bvh, 4.0), OK, "export_bvh: " + generator.get_last_error())
	var json := generator.timeline_to_json()
	check(json.contains('"waypoint"'), "the JSON has the waypoint")
	var file := FileAccess.open(json_path, FileAccess.WRITE)
	file.store_string(json)
	file.close()
	var output := []
	var arguments := [
		"--model",
		ProjectSettings.globalize_path(TestCharacter.MODEL),
		"--timeline",
		json_path,
		"--seconds",
		"4",
		"--seed",
		str(SEED),
		"--history-seconds",
		str(generator.history_seconds),
		"--out-bvh",
		cli_bvh
	]
	var code := OS.execute(cli, arguments, output, true)
	check_eq(code, 0, "ardy-generate ran: " + "\n".join(output))
	var ours := _bvh_frames(node_bvh)
	var theirs := _bvh_frames(cli_bvh)
	check(
		ours.size() == theirs.size() and ours.size() >= 60,
		"4 s of frames from each (the node %d, the CLI %d)" % [ours.size(), theirs.size()]
	)
	var worst := 0.0
	for frame in mini(ours.size(), theirs.size()):
		for channel in ours[frame].size():
			worst = maxf(worst, absf(ours[frame][channel] - theirs[frame][channel]))
	print("  node vs ardy-generate: largest channel difference %.6f over 4 s" % worst)
	check(
		worst <= 0.01,
		"the node's and the CLI's motion differ by %.6f, expected float noise" % worst
	)

	# And back: the JSON read as a timeline writes the same JSON.
	var imported: MotionTimeline = generator.timeline_from_json(json)
	check(imported != null, "imported: " + generator.get_last_error())
	check_eq(imported.waypoints.size(), 1, "one waypoint came back")
	check_eq(imported.prompts.size(), 2, "two prompts came back")
	var waypoint: MotionWaypoint = imported.waypoints[0]
	check(waypoint.position.distance_to(Vector3(0.5, 0, 3)) < 1e-3, "at %s" % waypoint.position)
	check(absf(waypoint.time - 3.0) < 1e-6, "the waypoint's time")
	generator.timeline = imported
	var again := JSON.parse_string(generator.timeline_to_json()) as Dictionary
	var first := JSON.parse_string(json) as Dictionary
	check_eq(again["prompts"], first["prompts"], "the prompts' JSON")
	var features_worst := 0.0
	var first_features: Array = first["constraints"][1]["features"]
	var again_features: Array = again["constraints"][1]["features"]
	for i in first_features.size():
		features_worst = maxf(features_worst, absf(first_features[i] - again_features[i]))
	check(features_worst < 1e-3, "the keyframe's features differ by %.5f" % features_worst)
	check(
		absf(again["constraints"][0]["x"] - first["constraints"][0]["x"]) < 1e-4,
		"the waypoint's JSON"
	)
	for path in [node_bvh, cli_bvh, json_path]:
		DirAccess.remove_absolute(path)
	character.dispose()


func test_a_bad_timeline_item_is_named_and_the_node_stays_usable() -> void:
	var timeline := _walk_then_hands_up()
	var path := MotionPath.new()
	path.points = PackedVector3Array([Vector3.ZERO])
	timeline.paths = [path]
	var character := _start(timeline)
	var generator := character.generator
	expect_error("timeline paths[0]: the path has 1 points")
	check(not generator.generate_clip(2.0), "generate_clip refused the timeline")
	check(generator.get_last_error().contains("timeline paths[0]"), generator.get_last_error())
	expect_error("seek_clip: there is no clip")
	generator.seek_clip(1.0)
	timeline.paths = []
	check(generator.generate_clip(2.0), "fixed, it generates: " + generator.get_last_error())
	check(absf(generator.get_clip_length() - 2.0) < 0.06, "a 2 s clip")
	var root: Variant = generator.get_clip_root(1.0)
	check(root is Transform3D, "get_clip_root gives a Transform3D")
	character.dispose()
