@tool
extends EditorPlugin
## The editor screenshots (scripts/editor_screenshots.sh copies this plugin into
## a copy of the demo project and enables it next to the ARDY plugin): opens
## res://authoring_example.tscn, selects its MotionGenerator (which shows the
## "Motion Timeline" dock), generates the timeline's clip, shows it at 2 s
## (the 3D view's camera comes from the scene's editor state, which
## build_scene.gd writes) and saves the editor window as
## editor_dock.png and the 3D viewport as editor_gizmos.png in the folder given
## by the environment variable ARDY_EDITOR_SCREENSHOTS, then quits.

const SCENE_PATH := "res://authoring_example.tscn"
const GENERATOR_PATH := "Character/MotionGenerator"
const SETTLE_FRAMES := 60
const MODEL_SECONDS := 120.0
const PLAYHEAD := 2.0
## The size of the move/rotate/scale gizmo (the editor's default is 80), so
## that it covers less of the character.
const MANIPULATOR_SIZE := 40


func _enter_tree() -> void:
	_run.call_deferred()


func _run() -> void:
	var folder: String = OS.get_environment("ARDY_EDITOR_SCREENSHOTS")
	var ok: bool = await _shoot(folder)
	print("editor screenshots: %s" % ("done" if ok else "FAILED"))
	get_tree().quit(0 if ok else 1)


func _shoot(folder: String) -> bool:
	if folder.is_empty():
		push_error("editor screenshots: set ARDY_EDITOR_SCREENSHOTS")
		return false
	await _frames(SETTLE_FRAMES)
	var settings: EditorSettings = EditorInterface.get_editor_settings()
	settings.set_setting("editors/3d/manipulator_gizmo_size", MANIPULATOR_SIZE)
	EditorInterface.open_scene_from_path(SCENE_PATH)
	await _frames(20)
	EditorInterface.set_main_screen_editor("3D")
	var root: Node = EditorInterface.get_edited_scene_root()
	var generator := root.get_node_or_null(GENERATOR_PATH) as MotionGenerator if root else null
	if generator == null:
		push_error("editor screenshots: no %s in %s" % [GENERATOR_PATH, SCENE_PATH])
		return false
	var selection: EditorSelection = EditorInterface.get_selection()
	selection.clear()
	selection.add_node(generator)
	EditorInterface.edit_node(generator)
	await _frames(10)
	var dock: Control = _find_dock()
	if dock == null:
		push_warning("editor screenshots: no Motion Timeline dock")
	else:
		make_bottom_panel_item_visible(dock)
	if not await _generate(generator, dock):
		return false
	if dock != null and dock.has_method("set_playhead"):
		dock.call("set_playhead", PLAYHEAD)
	else:
		generator.seek_clip(PLAYHEAD)
	generator.update_gizmos()
	var viewport: SubViewport = EditorInterface.get_editor_viewport_3d(0)
	await _frames(10)
	var window: Image = EditorInterface.get_base_control().get_viewport().get_texture().get_image()
	var saved: bool = _save(window, folder.path_join("editor_dock.png"))
	# The viewport alone, taller with the bottom panel closed.
	hide_bottom_panel()
	await _frames(20)
	window = EditorInterface.get_base_control().get_viewport().get_texture().get_image()
	var container := viewport.get_parent() as Control
	var area := Rect2i(container.get_global_rect()) if container else Rect2i()
	var gizmos: Image = viewport.get_texture().get_image()
	if area.size.x > 0 and Rect2i(Vector2i.ZERO, window.get_size()).encloses(area):
		# The viewport as shown, with its toolbar and overlays.
		gizmos = window.get_region(area)
	return _save(gizmos, folder.path_join("editor_gizmos.png")) and saved


func _generate(generator: MotionGenerator, dock: Control) -> bool:
	generator.preview_in_editor = true
	var waited := 0.0
	while not generator.is_model_loaded() and waited < MODEL_SECONDS:
		await get_tree().create_timer(0.25).timeout
		waited += 0.25
	if not generator.is_model_loaded():
		push_error("editor screenshots: the model did not load: %s" % generator.get_last_error())
		return false
	var button: Button = _find_button(dock, "Generate") if dock else null
	if button != null:
		button.pressed.emit()
		await _frames(5)
	if not generator.has_clip() and not generator.generate_clip():
		push_error("editor screenshots: generate_clip failed: %s" % generator.get_last_error())
		return false
	await _frames(5)
	return true


func _find_dock() -> Control:
	var docks: Array[Node] = EditorInterface.get_base_control().find_children(
		"MotionTimelineDock", "", true, false
	)
	return docks[0] as Control if not docks.is_empty() else null


func _find_button(node: Node, text: String) -> Button:
	for child: Node in node.find_children("*", "Button", true, false):
		var button := child as Button
		if button.text == text:
			return button
	return null


func _save(image: Image, path: String) -> bool:
	var error: Error = image.save_png(path)
	print(
		(
			"editor screenshots: %s %dx%d (%s)"
			% [path, image.get_width(), image.get_height(), error_string(error)]
		)
	)
	return error == OK


func _frames(count: int) -> void:
	for i: int in count:
		await get_tree().process_frame
