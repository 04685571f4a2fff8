@tool
extends EditorPlugin
## The editor test (tests/godot/editor/run.sh copies this plugin into a copy of
## the demo project and enables it next to the ARDY plugin): once the editor is
## up, drives the ARDY "Motion Timeline" dock on a MotionGenerator and checks its
## edits and their undo/redo. Prints "editor: N passed, N failed" and quits the
## editor with exit code 1 on any failure.

## Frames to let the editor settle before the checks.
const SETTLE_FRAMES := 30
## Seconds Play may take to load the model and generate the clip.
const PREVIEW_SECONDS := 120.0

var _passed := 0
var _failed := 0
var _undo_redo: EditorUndoRedoManager


func _enter_tree() -> void:
	_run.call_deferred()


func _run() -> void:
	for i in SETTLE_FRAMES:
		await get_tree().process_frame
	_undo_redo = EditorInterface.get_editor_undo_redo()
	var docks: Array[Node] = EditorInterface.get_base_control().find_children(
		"*", "MotionTimelineDock", true, false
	)
	_check(docks.size() == 1, "the ARDY plugin added one MotionTimelineDock (%d)" % docks.size())
	if docks.size() == 1:
		var dock: MotionTimelineDock = docks[0]
		await _test_dock(dock)
	print("editor: %d passed, %d failed" % [_passed, _failed])
	get_tree().quit(1 if _failed > 0 else 0)


func _test_dock(dock: MotionTimelineDock) -> void:
	var timeline := MotionTimeline.new()
	timeline.length = 8.0
	timeline.prompts = [_prompt(0.0, "a person walks"), _prompt(4.0, "a person waves")]
	timeline.waypoints = [_waypoint(2.0, Vector3(0, 0, 2)), _waypoint(5.0, Vector3(1, 0, 4))]
	var contact := MotionContact.new()
	contact.start_time = 1.0
	contact.end_time = 2.0
	timeline.contacts = [contact]
	var path := MotionPath.new()
	path.start_time = 5.0
	path.speed = 1.2
	path.points = PackedVector3Array([Vector3.ZERO, Vector3(0, 0, 2.4)])
	timeline.paths = [path]
	# The generators are in the edited scene (the project's main scene, which
	# the editor opens, or a new one), as the user's would be; never saved.
	var root := EditorInterface.get_edited_scene_root()
	if root == null:
		root = Node3D.new()
		root.name = "EditorTestRoot"
		EditorInterface.add_root_node(root)
		await get_tree().process_frame
	_check(EditorInterface.get_edited_scene_root() == root, "a scene is edited")
	var generator := _add_generator(root)
	generator.timeline = timeline
	dock.edit(generator)
	await get_tree().process_frame
	_test_move(dock, timeline)
	_test_item_at(dock)
	_test_drag(dock, timeline)
	_test_resize(dock, timeline)
	_test_menu(dock, timeline)
	_test_prompt_popup(dock, timeline)
	_test_wheel(dock)
	_test_add_remove(dock, timeline)
	_test_prompt_text(dock, timeline)
	_test_scrub(dock)
	_test_new_timeline(dock, root)
	await _test_character(dock, root)
	dock.edit(null)


func _test_move(dock: MotionTimelineDock, timeline: MotionTimeline) -> void:
	var waypoint: MotionWaypoint = timeline.waypoints[0]
	dock.move_item("waypoints", 0, 3.5)
	_check_time(waypoint.time, 3.5, "move_item moves the waypoint")
	var history := _history(waypoint)
	history.undo()
	_check_time(waypoint.time, 2.0, "undo puts the waypoint back")
	history.redo()
	_check_time(waypoint.time, 3.5, "redo moves it again")
	var contact: MotionContact = timeline.contacts[0]
	dock.move_item("contacts", 0, 4.0)
	_check(
		is_equal_approx(contact.start_time, 4.0) and is_equal_approx(contact.end_time, 5.0),
		"a moved contact keeps its length (%.2f..%.2f)" % [contact.start_time, contact.end_time]
	)
	_history(contact).undo()
	_check(
		is_equal_approx(contact.start_time, 1.0) and is_equal_approx(contact.end_time, 2.0),
		"one undo puts the contact back (%.2f..%.2f)" % [contact.start_time, contact.end_time]
	)


func _test_item_at(dock: MotionTimelineDock) -> void:
	var view := dock.track_view
	var at := Vector2(view.time_to_x(3.5), view.row_center("waypoints"))
	var hit: Dictionary = view.item_at(at)
	_check(hit == {"track": "waypoints", "index": 0}, "item_at finds the waypoint: %s" % hit)
	var prompt_at := Vector2(view.time_to_x(5.0), view.row_center("prompts"))
	hit = view.item_at(prompt_at)
	_check(hit == {"track": "prompts", "index": 1}, "item_at finds the second prompt: %s" % hit)
	hit = view.item_at(Vector2(view.time_to_x(7.5), view.row_center("keyframes")))
	_check(hit.is_empty(), "item_at finds nothing on an empty row: %s" % hit)


# A mouse drag of the second waypoint: previewed while dragging, one undo action.
func _test_drag(dock: MotionTimelineDock, timeline: MotionTimeline) -> void:
	var view := dock.track_view
	var waypoint: MotionWaypoint = timeline.waypoints[1]
	var y := view.row_center("waypoints")
	_mouse_button(view, Vector2(view.time_to_x(5.0), y), true)
	_mouse_motion(view, Vector2(view.time_to_x(5.6), y))
	_mouse_motion(view, Vector2(view.time_to_x(6.22), y))
	_check_time(waypoint.time, 6.2, "a drag previews the move, snapped to 0.1 s")
	_mouse_button(view, Vector2(view.time_to_x(6.22), y), false)
	_check_time(waypoint.time, 6.2, "the drag ends with the waypoint moved")
	_history(waypoint).undo()
	_check_time(waypoint.time, 5.0, "one undo undoes the whole drag")
	_history(waypoint).redo()
	_check_time(waypoint.time, 6.2, "redo redoes the drag")


# Drags of the blocks' right edges: a contact's end, a path's speed, the next
# prompt's time; each one undo action.
func _test_resize(dock: MotionTimelineDock, timeline: MotionTimeline) -> void:
	var contact: MotionContact = timeline.contacts[0]
	_drag(dock.track_view, "contacts", 2.0, 3.0)
	_check_time(contact.end_time, 3.0, "dragging a contact's right edge moves its end")
	_check_time(contact.start_time, 1.0, "and keeps its start")
	_history(contact).undo()
	_check_time(contact.end_time, 2.0, "undo puts the contact's end back")
	var path: MotionPath = timeline.paths[0]
	_drag(dock.track_view, "paths", 7.0, 8.0)
	_check_time(path.get_duration(), 3.0, "dragging a path's right edge sets its duration")
	_check_time(path.speed, 0.8, "through its speed")
	_history(path).undo()
	_check_time(path.speed, 1.2, "undo puts the path's speed back")
	var next: MotionPrompt = timeline.prompts[1]
	_drag(dock.track_view, "prompts", 4.0, 3.0)
	_check_time(next.time, 3.0, "dragging a prompt's right edge moves the next prompt")
	_history(next).undo()
	_check_time(next.time, 4.0, "undo puts the next prompt back")


# The right-click menu: "Add <kind> here" on empty row space, "Remove" on an item.
func _test_menu(dock: MotionTimelineDock, timeline: MotionTimeline) -> void:
	var view := dock.track_view
	var menu: PopupMenu = view.get("_menu")
	var at := Vector2(view.time_to_x(2.0), view.row_center("keyframes"))
	_mouse_button(view, at, true, MOUSE_BUTTON_RIGHT)
	_check(
		menu.visible and menu.item_count == 1 and menu.get_item_text(0) == "Add keyframe here",
		"a right click on an empty row offers to add (%s)" % menu.get_item_text(0)
	)
	menu.id_pressed.emit(menu.get_item_id(0))
	menu.hide()
	_check(timeline.keyframes.size() == 1, "the menu adds a keyframe")
	if timeline.keyframes.size() == 1:
		var keyframe: MotionKeyframe = timeline.keyframes[0]
		_check_time(keyframe.time, 2.0, "at the clicked time")
	_mouse_button(view, at, true, MOUSE_BUTTON_RIGHT)
	_check(
		menu.visible and menu.get_item_text(0) == "Remove",
		"a right click on an item offers to remove it (%s)" % menu.get_item_text(0)
	)
	menu.id_pressed.emit(menu.get_item_id(0))
	menu.hide()
	_check(timeline.keyframes.is_empty(), "the menu removes the keyframe")


# A double click on a prompt opens a line edit for its text.
func _test_prompt_popup(dock: MotionTimelineDock, timeline: MotionTimeline) -> void:
	var view := dock.track_view
	var prompt: MotionPrompt = timeline.prompts[1]
	var at := Vector2(view.time_to_x(5.0), view.row_center("prompts"))
	_mouse_button(view, at, true, MOUSE_BUTTON_LEFT, true)
	_mouse_button(view, at, false)
	var popup: PopupPanel = dock.get("_prompt_popup")
	var line: LineEdit = dock.get("_prompt_edit")
	_check(
		popup.visible and line.text == "a person waves",
		"a double click on a prompt opens its text (%s)" % line.text
	)
	line.text_submitted.emit("a person bows")
	_check(prompt.text == "a person bows" and not popup.visible, "submitting sets the text")
	_history(prompt).undo()
	_check(prompt.text == "a person waves", "undo restores it")


# Ctrl+wheel zooms about the pointer; the wheel scrolls.
func _test_wheel(dock: MotionTimelineDock) -> void:
	var view := dock.track_view
	var zoom := view.pixels_per_second
	var x := view.time_to_x(2.0)
	var wheel := InputEventMouseButton.new()
	wheel.button_index = MOUSE_BUTTON_WHEEL_UP
	wheel.pressed = true
	wheel.ctrl_pressed = true
	wheel.position = Vector2(x, view.row_center("prompts"))
	view.call("_gui_input", wheel)
	_check(view.pixels_per_second > zoom, "ctrl+wheel zooms in (%.1f)" % view.pixels_per_second)
	_check(is_equal_approx(view.time_to_x(2.0), x), "about the time under the pointer")
	wheel.ctrl_pressed = false
	wheel.button_index = MOUSE_BUTTON_WHEEL_DOWN
	var scroll := view.scroll_seconds
	view.call("_gui_input", wheel)
	_check(view.scroll_seconds > scroll, "the wheel scrolls (%.2f s)" % view.scroll_seconds)
	view.pixels_per_second = zoom
	view.scroll_seconds = 0.0


func _test_add_remove(dock: MotionTimelineDock, timeline: MotionTimeline) -> void:
	dock.add_item("prompts", 6.0)
	_check(timeline.prompts.size() == 3, "add_item adds a prompt (%d)" % timeline.prompts.size())
	var added: MotionPrompt = timeline.prompts[timeline.prompts.size() - 1]
	_check(
		is_equal_approx(added.time, 6.0) and added.text == "a person walks",
		"the added prompt is at 6 s with the default text"
	)
	_history(timeline).undo()
	_check(timeline.prompts.size() == 2, "undo removes the added prompt")
	dock.add_item("contacts", 3.0)
	var contacts := timeline.contacts
	_check(contacts.size() == 2, "add_item adds a contact (%d)" % contacts.size())
	dock.remove_item("waypoints", 0)
	_check(timeline.waypoints.size() == 1, "remove_item removes a waypoint")
	_history(timeline).undo()
	_check(timeline.waypoints.size() == 2, "undo brings the waypoint back")
	_history(timeline).undo()
	_check(timeline.contacts.size() == 1, "undo removes the added contact")


func _test_prompt_text(dock: MotionTimelineDock, timeline: MotionTimeline) -> void:
	var prompt: MotionPrompt = timeline.prompts[1]
	dock.set_prompt_text(1, "a person jumps")
	_check(prompt.text == "a person jumps", "set_prompt_text edits the prompt")
	_history(prompt).undo()
	_check(prompt.text == "a person waves", "undo restores the prompt text")


func _test_scrub(dock: MotionTimelineDock) -> void:
	var view := dock.track_view
	_check_time(dock.get_playhead(), 0.0, "the playhead starts at 0")
	var ruler_y := view.RULER_HEIGHT * 0.5
	_mouse_button(view, Vector2(view.time_to_x(1.5), ruler_y), true)
	_mouse_motion(view, Vector2(view.time_to_x(2.25), ruler_y))
	_mouse_button(view, Vector2(view.time_to_x(2.25), ruler_y), false)
	_check_time(dock.get_playhead(), 2.25, "dragging on the ruler scrubs the playhead")


func _test_new_timeline(dock: MotionTimelineDock, root: Node) -> void:
	var generator := _add_generator(root)
	dock.edit(generator)
	dock.call("_on_new_pressed")
	_check(generator.timeline != null, "New Timeline gives the generator a timeline")
	_history(generator).undo()
	_check(generator.timeline == null, "undo takes the new timeline away")
	dock.edit(null)


# On a character (the demo's mannequin rig): the items that read the skeleton,
# then Play, which turns the editor preview on, waits for the model, generates
# the clip and plays it to the timeline's end.
func _test_character(dock: MotionTimelineDock, root: Node) -> void:
	var character := Node3D.new()
	character.name = "TestCharacter"
	character.position = Vector3(1, 0, 2)
	root.add_child(character, true)
	var skeleton := Mannequin.build()
	character.add_child(skeleton)
	var generator := MotionGenerator.new()
	generator.skeleton = NodePath("../Skeleton3D")
	character.add_child(generator)
	var timeline := MotionTimeline.new()
	timeline.length = 2.0
	timeline.prompts = [_prompt(0.0, "a person walks")]
	generator.timeline = timeline
	dock.edit(generator)
	dock.add_item("keyframes", 1.0)
	var keyframe: MotionKeyframe = timeline.keyframes[0]
	_check(
		keyframe.pose.size() == skeleton.get_bone_count(),
		"an added keyframe holds the skeleton's pose (%d bones)" % keyframe.pose.size()
	)
	dock.add_item("joint_targets", 1.5)
	var target: MotionJointTarget = timeline.joint_targets[0]
	_check(
		target.bone == "RightHand" and target.use_position and target.position.y > 0.5,
		"an added joint target is on the right hand (%s)" % target.position
	)
	dock.add_item("waypoints", 0.5)
	var waypoint: MotionWaypoint = timeline.waypoints[0]
	_check(
		waypoint.position.is_equal_approx(Vector3(1, 0, 3)),
		"an added waypoint is 1 m ahead of the character (%s)" % waypoint.position
	)
	for i in 3:
		_history(timeline).undo()
	_check(
		timeline.keyframes.is_empty() and timeline.joint_targets.is_empty(),
		"undo takes the added items away"
	)
	dock.call("_request", "play")
	var waited := 0.0
	while not generator.has_clip() and waited < PREVIEW_SECONDS:
		if dock.get_status().begins_with("Generation failed"):
			break
		await get_tree().create_timer(0.25).timeout
		waited += 0.25
	_check(generator.has_clip(), "Play generates the clip (%s)" % dock.get_status())
	if generator.has_clip():
		await get_tree().create_timer(0.5).timeout
		_check(
			dock.get_playhead() > 0.0, "playing advances the playhead (%.2f)" % dock.get_playhead()
		)
		waited = 0.0
		while dock.is_playing() and waited < 5.0:
			await get_tree().create_timer(0.25).timeout
			waited += 0.25
		_check(not dock.is_playing(), "playing stops at the timeline's end")
		_check_time(dock.get_playhead(), 2.0, "the playhead stops at the end")
		dock.set_playhead(1.0)
		_check_time(dock.get_playhead(), 1.0, "set_playhead scrubs the clip")
		_test_bake(dock, character)
		_test_exports(dock)
	dock.edit(null)
	generator.preview_in_editor = false


func _test_bake(dock: MotionTimelineDock, character: Node3D) -> void:
	var player := AnimationPlayer.new()
	character.add_child(player)
	var baked := dock.bake_into(player, "motion")
	_check(baked, "bake_into bakes (%s)" % dock.get_status())
	if not baked:
		return
	_check(player.has_animation(&"motion"), "the player has the baked animation")
	var animation := player.get_animation(&"motion")
	_check(
		animation.get_track_count() > 0 and absf(animation.length - 2.0) <= 0.1,
		(
			"the animation has tracks and about the timeline's length (%d tracks, %.2f s)"
			% [animation.get_track_count(), animation.length]
		)
	)
	_history(player).undo()
	_check(not player.has_animation(&"motion"), "undo takes the baked animation away")
	_history(player).redo()
	_check(player.has_animation(&"motion"), "redo bakes it again")


func _test_exports(dock: MotionTimelineDock) -> void:
	# In the throwaway project, in a folder the editor does not scan.
	var folder := ProjectSettings.globalize_path("res://.editor_test")
	DirAccess.make_dir_recursive_absolute(folder)
	var json_path := folder.path_join("timeline.json")
	_check(dock.export_json(json_path) == OK, "export_json writes (%s)" % dock.get_status())
	var parsed: Variant = JSON.parse_string(FileAccess.get_file_as_string(json_path))
	_check(parsed is Dictionary, "the exported JSON parses")
	var bvh_path := folder.path_join("motion.bvh")
	_check(dock.export_bvh(bvh_path) == OK, "export_bvh writes (%s)" % dock.get_status())
	var bvh := FileAccess.get_file_as_string(bvh_path)
	_check(bvh.begins_with("HIERARCHY"), "the exported BVH starts with HIERARCHY")


func _add_generator(root: Node) -> MotionGenerator:
	var generator := MotionGenerator.new()
	root.add_child(generator, true)
	generator.owner = root
	return generator


func _history(object: Object) -> UndoRedo:
	return _undo_redo.get_history_undo_redo(_undo_redo.get_object_history_id(object))


# A left-button drag on the row of `track` from `from` to `to` seconds.
func _drag(view: Control, track: String, from: float, to: float) -> void:
	var y: float = view.call("row_center", track)
	var start: float = view.call("time_to_x", from)
	var end: float = view.call("time_to_x", to)
	_mouse_button(view, Vector2(start, y), true)
	_mouse_motion(view, Vector2((start + end) / 2.0, y))
	_mouse_motion(view, Vector2(end, y))
	_mouse_button(view, Vector2(end, y), false)


func _mouse_button(
	view: Control,
	at: Vector2,
	pressed: bool,
	button: MouseButton = MOUSE_BUTTON_LEFT,
	double_click := false
) -> void:
	var event := InputEventMouseButton.new()
	event.button_index = button
	event.pressed = pressed
	event.double_click = double_click
	event.position = at
	view.call("_gui_input", event)


func _mouse_motion(view: Control, at: Vector2) -> void:
	var event := InputEventMouseMotion.new()
	event.button_mask = MOUSE_BUTTON_MASK_LEFT
	event.position = at
	view.call("_gui_input", event)


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


func _check_time(actual: float, expected: float, what: String) -> void:
	_check(is_equal_approx(actual, expected), "%s (%.3f, expected %.3f)" % [what, actual, expected])


func _check(ok: bool, what: String) -> void:
	if ok:
		_passed += 1
		print("PASS %s" % what)
	else:
		_failed += 1
		print("FAIL %s" % what)
