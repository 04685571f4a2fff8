extends SceneTree
## Drives the demo scene as a player does, through Input.parse_input_event
## (SyntheticInput): a held W key walks the character where the camera looks
## and releasing it stops it, a click on the ground places a waypoint it
## reaches and a right click clears it, a prompt typed into the box changes
## what it does and comes back with the Up key, a preset button applies its
## prompt, a keyframe preset shows a ghost that goes once the pose is reached,
## the settings panel's path guidance slider and default box set the node's
## path_guidance_scale, and the open panel follows a value set by code.
## tests/godot/run.sh runs it in a copy of the demo project; it prints
## "N passed, N failed".

var main: Node3D
var generator: MotionGenerator
var passed := 0
var failed := 0
var hips_track: Array[Dictionary] = []


func _initialize() -> void:
	_run()


func _run() -> void:
	# The headless window is 64 x 64 pixels: lay the UI out as on a 1280 x 720
	# screen, scaled down (SyntheticInput clicks through the scaling).
	root.content_scale_mode = Window.CONTENT_SCALE_MODE_CANVAS_ITEMS
	root.content_scale_aspect = Window.CONTENT_SCALE_ASPECT_IGNORE
	root.content_scale_size = Vector2i(1280, 720)
	main = load("res://main.tscn").instantiate()
	root.add_child(main)
	var deadline := Time.get_ticks_msec() + 90000
	while (
		(main.get("generator") == null or not main.generator.is_generating())
		and Time.get_ticks_msec() < deadline
	):
		await process_frame
	generator = main.get("generator")
	_check(generator != null and generator.is_generating(), "the demo generates")
	if generator == null:
		_finish()
		return
	var skeleton: Skeleton3D = main.get_node("Character/Skeleton3D")
	var bone_height := func(bone: String) -> float:
		return (
			(skeleton.global_transform * skeleton.get_bone_global_pose(skeleton.find_bone(bone)))
			. origin
			. y
		)
	skeleton.skeleton_updated.connect(
		func() -> void:
			(
				hips_track
				. append(
					{
						"time": generator.get_time(),
						"hips": main.character.hips,
						"hands_over_head":
						(
							minf(bone_height.call("LeftHand"), bone_height.call("RightHand"))
							- bone_height.call("Head")
						),
					}
				)
			)
	)
	await _wait_motion(1.0)
	await _walk_with_the_w_key()
	await _click_a_waypoint()
	await _type_a_prompt()
	await _add_a_keyframe_preset()
	await _set_path_guidance()
	_finish()


func _walk_with_the_w_key() -> void:
	var camera: Camera3D = main.get_node("Camera")
	var forward := -camera.global_basis.z
	forward = Vector3(forward.x, 0, forward.z).normalized()
	SyntheticInput.key(KEY_W, true)
	var pressed_at := generator.get_time()
	await _wait_motion(pressed_at + 3.0)
	var moved := _hips_at(pressed_at + 3.0) - _hips_at(pressed_at + 2.0)
	moved.y = 0
	var angle := rad_to_deg(moved.angle_to(forward))
	print("  W held: %.2f m/s, %.0f degrees from the camera's forward" % [moved.length(), angle])
	_check(moved.length() > 0.6 and angle < 30.0, "holding W walks where the camera looks")
	SyntheticInput.key(KEY_W, false)
	var released_at := generator.get_time()
	await _wait_motion(released_at + 3.0)
	var drift := _hips_at(released_at + 3.0) - _hips_at(released_at + 2.0)
	drift.y = 0
	print("  W released: %.2f m/s a few seconds later" % drift.length())
	_check(drift.length() < 0.3, "releasing W stops the character (%.2f m/s)" % drift.length())


func _click_a_waypoint() -> void:
	var camera: Camera3D = main.get_node("Camera")
	var hips: Vector3 = main.character.hips
	# A point on the ground 2 m beyond the character, as seen from the camera.
	var forward := -camera.global_basis.z
	forward = Vector3(forward.x, 0, forward.z).normalized()
	var target := Vector3(hips.x, 0, hips.z) + forward * 2.0
	var screen := camera.unproject_position(target)
	var reached: Array[int] = []
	generator.waypoint_reached.connect(func(index: int) -> void: reached.append(index))
	SyntheticInput.click(root, screen)
	await process_frame
	_check(
		generator.get_waypoints().size() == 1,
		"the click on the ground (not on the UI) placed a waypoint"
	)
	var clicked_at := generator.get_time()
	await _wait_motion(clicked_at + 6.0)
	var closest := INF
	for sample in hips_track:
		if sample["time"] > clicked_at:
			var at: Vector3 = sample["hips"]
			closest = minf(closest, Vector2(at.x - target.x, at.z - target.z).length())
	print("  click on the ground: the hips passed %.2f m from the clicked point" % closest)
	_check(closest < 0.4, "a clicked waypoint is reached (%.2f m)" % closest)
	_check(reached.has(0), "waypoint_reached fired for the click")
	SyntheticInput.click(root, screen, MOUSE_BUTTON_RIGHT)
	await process_frame
	await process_frame  # the rings are freed at the end of the frame that cleared them
	var rings := main.get_node("Controls/ClickWaypoints").find_children(
		"*", "MeshInstance3D", true, false
	)
	# What is left is the (empty) path line.
	_check(
		generator.get_waypoints().is_empty() and rings.size() == 1,
		"a right click clears the waypoints and their rings (%d meshes left)" % rings.size()
	)


func _type_a_prompt() -> void:
	var box: LineEdit = main.prompt_bar.box()
	var started: Array[String] = []
	generator.prompt_started.connect(func(text: String) -> void: started.append(text))
	SyntheticInput.click(root, box.get_global_rect().get_center())
	await process_frame
	_check(box.has_focus(), "a click focuses the prompt box")
	await SyntheticInput.type_line(self, "wave with the right hand")
	_check(
		generator.prompt == "wave with the right hand",
		"Enter applied the typed prompt: " + generator.prompt
	)
	_check(not box.has_focus(), "Enter gives the keys back to steering")
	var typed_at := generator.get_time()
	await _wait_motion(typed_at + 2.0)
	print("  typed prompt: prompts started %s" % [started])
	_check(started.has("wave with the right hand"), "the typed prompt reached the motion")
	# The prompt comes back from the history with the Up key.
	SyntheticInput.click(root, box.get_global_rect().get_center())
	await process_frame
	SyntheticInput.key(KEY_UP, true)
	SyntheticInput.key(KEY_UP, false)
	await process_frame
	_check(box.text == "wave with the right hand", "Up recalls the last prompt: '%s'" % box.text)
	box.clear()
	box.release_focus()


func _add_a_keyframe_preset() -> void:
	var stand: Button = main.get_node("UI/PromptBar/Presets").find_child("stand still", true, false)
	SyntheticInput.click(root, stand.get_global_rect().get_center())
	await process_frame
	_check(generator.prompt == "stand still", "a preset prompt button applies its prompt")
	await _wait_motion(generator.get_time() + 2.0)
	var button: Button = main.get_node("UI/Actions").find_child("Hands up*", true, false)
	var presets: Node3D = main.keyframe_presets
	var reached: Array[int] = []
	generator.keyframe_reached.connect(func(index: int) -> void: reached.append(index))
	SyntheticInput.click(root, button.get_global_rect().get_center())
	await process_frame
	var keyframes := generator.get_keyframes()
	_check(keyframes.size() == 1, "the preset button added a keyframe (%d)" % keyframes.size())
	var ghosts := presets.find_children("Ghost*", "Skeleton3D", false, false)
	_check(ghosts.size() == 1, "the keyframe shows a ghost pose (%d)" % ghosts.size())
	if keyframes.is_empty() or ghosts.is_empty():
		return
	# The ghost stands where the character stands.
	var ghost_place: Vector3 = ghosts[0].global_position
	var hips: Vector3 = main.character.hips
	var apart := Vector2(ghost_place.x - hips.x, ghost_place.z - hips.z).length()
	print("  keyframe ghost %.2f m from the hips" % apart)
	_check(apart < 0.5, "the ghost stands at the character (%.2f m)" % apart)
	var due: float = keyframes[0].time
	await _wait_motion(due + 1.5)
	_check(reached.has(0), "keyframe_reached fired for the preset")
	var highest := -INF
	for sample in hips_track:
		if absf(sample["time"] - due) < 0.3:
			highest = maxf(highest, sample["hands_over_head"])
	print("  hands up: both hands %.2f m over the head at the keyframe" % highest)
	_check(highest > 0.25, "the character raised both hands over its head (%.2f m)" % highest)
	await process_frame
	var left := presets.find_children("Ghost*", "Skeleton3D", false, false).size()
	_check(left == 0, "the ghost goes once its pose is reached (%d left)" % left)


func _set_path_guidance() -> void:
	var panel: Control = main.get_node("UI/Settings")
	var toggle: Button = panel.get_child(0)
	SyntheticInput.click(root, toggle.get_global_rect().get_center())
	await process_frame
	var row_title: Label = null
	for label: Label in panel.find_children("*", "Label", true, false):
		if label.text == "Path guidance":
			row_title = label
	if row_title == null:
		_check(false, "the settings panel has a Path guidance row")
		return
	_check(row_title.is_visible_in_tree(), "the Settings button opens the panel")
	# A row is title, slider, value, default box.
	var grid := row_title.get_parent()
	var slider: HSlider = grid.get_child(row_title.get_index() + 1)
	var value: Label = grid.get_child(row_title.get_index() + 2)
	var use_default: CheckBox = grid.get_child(row_title.get_index() + 3)
	_check(
		generator.path_guidance_scale < 0.0 and use_default.button_pressed and value.text == "auto",
		"the panel shows the model's own path guidance ('%s')" % value.text
	)
	# A click a fifth of the way along the track moves the grabber there.
	var track := slider.get_global_rect()
	SyntheticInput.click(root, track.position + Vector2(track.size.x * 0.2, track.size.y * 0.5))
	await process_frame
	var fifth := slider.min_value + 0.2 * (slider.max_value - slider.min_value)
	var scale := generator.path_guidance_scale
	print(
		(
			"  path guidance slider: %.2f (a fifth along: %.2f), shown '%s'"
			% [scale, fifth, value.text]
		)
	)
	# The grabber's width shifts where a click lands by a step or so.
	_check(
		is_equal_approx(scale, slider.value) and absf(scale - fifth) <= 2.0 * slider.step,
		"a click on the slider sets path_guidance_scale (%.2f)" % scale
	)
	_check(
		not use_default.button_pressed and value.text == "%.2f" % generator.path_guidance_scale,
		"the panel shows the value set"
	)
	SyntheticInput.click(root, use_default.get_global_rect().get_center())
	await process_frame
	_check(
		generator.path_guidance_scale < 0.0 and value.text == "auto",
		"the default box gives it back to the model (%.2f)" % generator.path_guidance_scale
	)
	# A value other code sets while the panel is open shows within a frame.
	generator.path_guidance_scale = 0.35
	await process_frame
	await process_frame
	_check(
		(
			not use_default.button_pressed
			and value.text == "0.35"
			and is_equal_approx(slider.value, 0.35)
		),
		"the open panel follows a value set by code ('%s')" % value.text
	)
	generator.path_guidance_scale = -1.0
	SyntheticInput.click(root, toggle.get_global_rect().get_center())
	await process_frame
	_check(not row_title.is_visible_in_tree(), "the Settings button closes the panel")


func _wait_motion(seconds: float) -> void:
	var deadline := Time.get_ticks_msec() + int((seconds - generator.get_time() + 30.0) * 1000.0)
	while generator.get_time() < seconds and Time.get_ticks_msec() < deadline:
		await process_frame


func _hips_at(seconds: float) -> Vector3:
	var found := Vector3.INF
	for sample in hips_track:
		if sample["time"] <= seconds:
			found = sample["hips"]
	return found


func _check(condition: bool, what: String) -> void:
	if condition:
		passed += 1
		print("PASS demo: " + what)
	else:
		failed += 1
		printerr("FAIL demo: " + what)


func _finish() -> void:
	print("%d passed, %d failed" % [passed, failed])
	if main != null:
		main.free()
	quit(failed)
