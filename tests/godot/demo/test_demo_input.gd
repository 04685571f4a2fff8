extends SceneTree
## Drives the demo scene as a player does, through Input.parse_input_event:
## a held W key walks the character where the camera looks and releasing it
## stops it, a click on the ground places a waypoint it reaches, and a prompt
## typed into the box changes what it does. tests/godot/run.sh runs it in a
## copy of the demo project; it prints "N passed, N failed".

var main: Node3D
var generator: MotionGenerator
var passed := 0
var failed := 0
var hips_track: Array[Dictionary] = []


func _initialize() -> void:
	_run()


func _run() -> void:
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
	skeleton.skeleton_updated.connect(
		func() -> void: hips_track.append({"time": generator.get_time(), "hips": main.get("hips")})
	)
	await _wait_motion(1.0)
	await _walk_with_the_w_key()
	await _click_a_waypoint()
	await _type_a_prompt()
	_finish()


func _walk_with_the_w_key() -> void:
	var camera: Camera3D = main.get_node("Camera3D")
	var forward := -camera.global_basis.z
	forward = Vector3(forward.x, 0, forward.z).normalized()
	_key(KEY_W, true)
	var pressed_at := generator.get_time()
	await _wait_motion(pressed_at + 3.0)
	var moved := _hips_at(pressed_at + 3.0) - _hips_at(pressed_at + 2.0)
	moved.y = 0
	var angle := rad_to_deg(moved.angle_to(forward))
	print("  W held: %.2f m/s, %.0f degrees from the camera's forward" % [moved.length(), angle])
	_check(moved.length() > 0.6 and angle < 30.0, "holding W walks where the camera looks")
	_key(KEY_W, false)
	var released_at := generator.get_time()
	await _wait_motion(released_at + 3.0)
	var drift := _hips_at(released_at + 3.0) - _hips_at(released_at + 2.0)
	drift.y = 0
	print("  W released: %.2f m/s a few seconds later" % drift.length())
	_check(drift.length() < 0.3, "releasing W stops the character (%.2f m/s)" % drift.length())


func _click_a_waypoint() -> void:
	var camera: Camera3D = main.get_node("Camera3D")
	var hips: Vector3 = main.get("hips")
	# A point on the ground 2 m beyond the character, as seen from the camera.
	var forward := -camera.global_basis.z
	forward = Vector3(forward.x, 0, forward.z).normalized()
	var target := Vector3(hips.x, 0, hips.z) + forward * 2.0
	var screen := camera.unproject_position(target)
	var reached: Array[int] = []
	generator.waypoint_reached.connect(func(index: int) -> void: reached.append(index))
	# Headless, the window is 64 x 64 pixels and the UI covers all of it.
	var ui: CanvasLayer = main.get_node("UI")
	ui.visible = false
	_left_click(screen)
	await process_frame
	ui.visible = true
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


func _type_a_prompt() -> void:
	var box: LineEdit = main.get_node("UI/Prompt")
	var started: Array[String] = []
	generator.prompt_started.connect(func(text: String) -> void: started.append(text))
	var centre := box.get_global_rect().get_center()
	_left_click(centre)
	await process_frame
	_check(box.has_focus(), "a click focuses the prompt box")
	for character in "wave with the right hand":
		var key := InputEventKey.new()
		key.pressed = true
		key.unicode = character.unicode_at(0)
		key.keycode = OS.find_keycode_from_string(character) if character != " " else KEY_SPACE
		Input.parse_input_event(key)
		await process_frame
	_key(KEY_ENTER, true)
	_key(KEY_ENTER, false)
	await process_frame
	_check(
		generator.prompt == "wave with the right hand",
		"Enter applied the typed prompt: " + generator.prompt
	)
	_check(not box.has_focus(), "Enter gives the keys back to steering")
	var typed_at := generator.get_time()
	await _wait_motion(typed_at + 2.0)
	print("  typed prompt: prompts started %s" % [started])
	_check(started.has("wave with the right hand"), "the typed prompt reached the motion")


func _left_click(screen_position: Vector2) -> void:
	for pressed in [true, false]:
		var click := InputEventMouseButton.new()
		click.button_index = MOUSE_BUTTON_LEFT
		click.pressed = pressed
		click.position = screen_position
		click.global_position = screen_position
		Input.parse_input_event(click)


func _key(keycode: Key, pressed: bool) -> void:
	var key := InputEventKey.new()
	key.keycode = keycode
	key.physical_keycode = keycode
	key.pressed = pressed
	Input.parse_input_event(key)


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
