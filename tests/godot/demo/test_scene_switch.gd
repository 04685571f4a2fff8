extends SceneTree
## The demo's two scenes reach each other through their buttons, clicked as
## a player clicks them: "Crowd scene" opens the crowd, "Back to the
## character" the main scene. tests/godot/run.sh runs it in a copy of the demo
## project; it prints "N passed, N failed".

var passed := 0
var failed := 0


func _initialize() -> void:
	_run()


func _run() -> void:
	# The headless window is 64 x 64 pixels: lay the UI out as on a 1280 x 720
	# screen, scaled down (SyntheticInput clicks through the scaling).
	root.content_scale_mode = Window.CONTENT_SCALE_MODE_CANVAS_ITEMS
	root.content_scale_aspect = Window.CONTENT_SCALE_ASPECT_IGNORE
	root.content_scale_size = Vector2i(1280, 720)
	change_scene_to_file("res://main.tscn")
	await _scene_named("Main")
	var button: Button = current_scene.get_node("UI/Actions").find_child("Crowd scene", true, false)
	SyntheticInput.click(root, button.get_global_rect().get_center())
	_check(await _scene_named("Crowd"), "the Crowd scene button opens the crowd")
	var back: Button = current_scene.get_node("UI/Back")
	SyntheticInput.click(root, back.get_global_rect().get_center())
	_check(await _scene_named("Main"), "the Back button returns to the character")
	print("%d passed, %d failed" % [passed, failed])
	quit(failed)


func _scene_named(scene_name: String) -> bool:
	for frame in 300:
		await process_frame
		if current_scene != null and current_scene.name == scene_name:
			await process_frame  # its UI laid out
			return true
	return false


func _check(condition: bool, what: String) -> void:
	if condition:
		passed += 1
		print("PASS scenes: " + what)
	else:
		failed += 1
		printerr("FAIL scenes: " + what)
