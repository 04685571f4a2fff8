@tool
class_name MotionTimelineDock
extends VBoxContainer
## The "Motion Timeline" bottom panel: the `timeline` of the selected
## MotionGenerator as tracks (timeline_track_view.gd), with a toolbar to make a
## timeline, preview it on the character (generate, play, scrub), bake it into
## an AnimationPlayer and export it as BVH or JSON. Every edit of the timeline
## is an editor undo action.

const TrackView := preload("res://addons/ardy/editor/timeline_track_view.gd")
const BAKE_FPS := 30.0
const DEFAULT_PROMPT := "a person walks"
const DEFAULT_ANIMATION := "motion"
const JOINT_TARGET_BONE := "RightHand"
const PATH_LENGTH := 2.0
const CONTACT_SECONDS := 1.0
const NO_TIMELINE := "This generator has no timeline."

## The track area (public for tests: item_at(), time_to_x(), row_center()).
var track_view: TrackView

var _generator: MotionGenerator
## Whether `_generator` was set (it may have been freed since).
var _has_generator := false
var _undo_redo: EditorUndoRedoManager
var _playhead := 0.0
var _playing := false
## What waits for the model to load: "play", "generate", "bake", "bvh" or "".
var _pending := ""
var _pending_path := ""

var _new_button: Button
var _play_button: Button
var _time_spin: SpinBox
var _length_label: Label
var _generate_button: Button
var _player_option: OptionButton
var _animation_edit: LineEdit
var _bake_button: Button
var _bvh_button: Button
var _json_button: Button
var _status: Label
var _file_dialog: EditorFileDialog
var _file_kind := ""
var _prompt_popup: PopupPanel
var _prompt_edit: LineEdit
var _prompt_index := -1


func _init() -> void:
	custom_minimum_size = Vector2(0, 220)
	_build_toolbar()
	track_view = TrackView.new()
	track_view.size_flags_vertical = SIZE_EXPAND_FILL
	track_view.scrubbed.connect(_on_scrubbed)
	track_view.drag_finished.connect(_commit_changes)
	track_view.add_requested.connect(add_item)
	track_view.remove_requested.connect(remove_item)
	track_view.prompt_edit_requested.connect(_open_prompt_editor)
	add_child(track_view)
	_build_prompt_editor()
	_file_dialog = EditorFileDialog.new()
	_file_dialog.file_mode = EditorFileDialog.FILE_MODE_SAVE_FILE
	_file_dialog.access = EditorFileDialog.ACCESS_FILESYSTEM
	_file_dialog.file_selected.connect(_on_file_selected)
	add_child(_file_dialog)
	_refresh()


## Shows the timeline of `generator` (a MotionGenerator; null shows nothing).
func edit(generator: Node) -> void:
	var next := generator as MotionGenerator
	if next == _generator:
		return
	_stop()
	_pending = ""
	_generator = next
	_has_generator = next != null
	_playhead = 0.0
	_status.text = ""
	_refresh()


## The undo/redo every edit goes through (the plugin's get_undo_redo()).
func set_undo_redo(undo_redo: EditorUndoRedoManager) -> void:
	_undo_redo = undo_redo


## The playhead, seconds on the motion clock.
func get_playhead() -> float:
	return _playhead


## Whether Play is on.
func is_playing() -> bool:
	return _playing


## The status line (the last result or error of Generate, Bake and the exports).
func get_status() -> String:
	return _status.text


## Moves the playhead and shows the clip's pose there (when there is a clip).
func set_playhead(seconds: float) -> void:
	_playhead = maxf(seconds, 0.0)
	var timeline := _timeline()
	if timeline != null:
		_playhead = minf(_playhead, timeline.length)
	if _generator != null and _generator.has_clip():
		_generator.seek_clip(_playhead)
	_show_playhead()


## Moves item `index` of `track` (a timeline array: "prompts", "waypoints",
## "paths", "keyframes", "joint_targets", "contacts") to start at `new_time`, as
## one undo action (the action a drag of the item ends with).
func move_item(track: String, index: int, new_time: float) -> void:
	if _timeline() == null or index < 0 or index >= track_view.get_items(track).size():
		return
	var changes := track_view.capture(track, index, false)
	track_view.apply_move(track, index, new_time)
	_commit_changes("Move %s" % _item_name(track), changes)


## Adds an item of `track` at `time` (what "Add <kind> here" does).
func add_item(track: String, time: float) -> void:
	var timeline := _timeline()
	if timeline == null or not TrackView.TRACKS.has(track):
		return
	var items: Array = track_view.get_items(track).duplicate()
	items.append(_make_item(track, time))
	_set_items("Add %s" % _item_name(track), track, items)


## Removes item `index` of `track`.
func remove_item(track: String, index: int) -> void:
	var items: Array = track_view.get_items(track).duplicate()
	if index < 0 or index >= items.size():
		return
	items.remove_at(index)
	_set_items("Remove %s" % _item_name(track), track, items)


## Sets the text of prompt `index`.
func set_prompt_text(index: int, text: String) -> void:
	var prompts := track_view.get_items("prompts")
	if index < 0 or index >= prompts.size():
		return
	var prompt: MotionPrompt = prompts[index]
	var changes: Array[Dictionary] = [{"object": prompt, "property": &"text", "value": prompt.text}]
	prompt.text = text
	_commit_changes("Edit Prompt", changes)


func _process(delta: float) -> void:
	if _has_generator and not is_instance_valid(_generator):
		_generator = null
		_has_generator = false
		_stop()
		_refresh()
	if _generator != null and track_view.timeline != _generator.timeline:
		_refresh()
	if _playing:
		_advance(delta)


func _advance(delta: float) -> void:
	var timeline := _timeline()
	if timeline == null or not _generator.has_clip():
		_stop()
		return
	var time := _playhead + delta
	if time >= timeline.length:
		if timeline.loop and timeline.length > 0.0:
			time = fposmod(time, timeline.length)
		else:
			time = timeline.length
			_stop()
	_playhead = time
	_generator.seek_clip(_playhead)
	_show_playhead()


func _timeline() -> MotionTimeline:
	if _generator == null:
		return null
	return _generator.timeline


# The toolbar and track view as the generator and its timeline are now.
func _refresh() -> void:
	var timeline := _timeline()
	track_view.timeline = timeline
	var has_generator := _generator != null
	var has_timeline := timeline != null
	_new_button.visible = has_generator and not has_timeline
	for control: BaseButton in [_play_button, _generate_button, _bake_button, _bvh_button]:
		control.disabled = not has_timeline
	_json_button.disabled = not has_timeline
	_time_spin.editable = has_timeline
	_time_spin.max_value = timeline.length if has_timeline else 10.0
	_length_label.text = "/ %.2f s" % _time_spin.max_value
	if not has_generator:
		_status.text = "Select a MotionGenerator to edit its timeline."
	elif not has_timeline and _status.text.is_empty():
		_status.text = NO_TIMELINE
	elif has_timeline and _status.text == NO_TIMELINE:
		_status.text = ""
	_refresh_players()
	_show_playhead()


func _show_playhead() -> void:
	_time_spin.set_value_no_signal(_playhead)
	track_view.playhead = _playhead


func _build_toolbar() -> void:
	var bar := HBoxContainer.new()
	add_child(bar)
	_new_button = _button(bar, "New Timeline", _on_new_pressed)
	_new_button.tooltip_text = "Give the generator an empty MotionTimeline."
	_play_button = _button(bar, "Play", Callable())
	_play_button.toggle_mode = true
	_play_button.toggled.connect(_on_play_toggled)
	_time_spin = SpinBox.new()
	_time_spin.step = 0.01
	_time_spin.suffix = "s"
	_time_spin.custom_minimum_size = Vector2(90, 0)
	_time_spin.tooltip_text = "The playhead (seconds on the motion clock)."
	_time_spin.value_changed.connect(set_playhead)
	bar.add_child(_time_spin)
	_length_label = Label.new()
	bar.add_child(_length_label)
	bar.add_child(VSeparator.new())
	_generate_button = _button(bar, "Generate", func() -> void: _request("generate"))
	_generate_button.tooltip_text = "Generate the timeline's motion and preview it."
	bar.add_child(VSeparator.new())
	_player_option = OptionButton.new()
	_player_option.tooltip_text = "The AnimationPlayer to bake into."
	_player_option.get_popup().about_to_popup.connect(_refresh_players)
	bar.add_child(_player_option)
	_animation_edit = LineEdit.new()
	_animation_edit.text = DEFAULT_ANIMATION
	_animation_edit.custom_minimum_size = Vector2(100, 0)
	_animation_edit.tooltip_text = "The name of the baked animation."
	bar.add_child(_animation_edit)
	_bake_button = _button(bar, "Bake", func() -> void: _request("bake"))
	bar.add_child(VSeparator.new())
	_bvh_button = _button(bar, "Export BVH…", func() -> void: _open_file_dialog("bvh"))
	_json_button = _button(bar, "Export JSON…", func() -> void: _open_file_dialog("json"))
	_status = Label.new()
	_status.size_flags_horizontal = SIZE_EXPAND_FILL
	_status.text_overrun_behavior = TextServer.OVERRUN_TRIM_ELLIPSIS
	_status.clip_text = true
	bar.add_child(_status)


func _button(bar: HBoxContainer, text: String, on_pressed: Callable) -> Button:
	var button := Button.new()
	button.text = text
	if on_pressed.is_valid():
		button.pressed.connect(on_pressed)
	bar.add_child(button)
	return button


func _build_prompt_editor() -> void:
	_prompt_popup = PopupPanel.new()
	_prompt_edit = LineEdit.new()
	_prompt_edit.custom_minimum_size = Vector2(320, 0)
	_prompt_edit.text_submitted.connect(_on_prompt_submitted)
	_prompt_popup.add_child(_prompt_edit)
	add_child(_prompt_popup)


func _open_prompt_editor(index: int) -> void:
	var prompts := track_view.get_items("prompts")
	if index < 0 or index >= prompts.size():
		return
	var prompt: MotionPrompt = prompts[index]
	_prompt_index = index
	_prompt_edit.text = prompt.text
	var span := track_view.item_span("prompts", index)
	var at := (
		track_view.get_screen_position()
		+ Vector2(track_view.time_to_x(span.x), track_view.row_center("prompts"))
	)
	_prompt_popup.reset_size()
	_prompt_popup.position = Vector2i(at)
	_prompt_popup.popup()
	_prompt_edit.grab_focus()
	_prompt_edit.select_all()


func _on_prompt_submitted(text: String) -> void:
	_prompt_popup.hide()
	set_prompt_text(_prompt_index, text.strip_edges())


func _on_new_pressed() -> void:
	if _generator == null or _generator.timeline != null:
		return
	var timeline := MotionTimeline.new()
	if _undo_redo == null:
		_generator.timeline = timeline
	else:
		_undo_redo.create_action("New Motion Timeline")
		_undo_redo.add_do_property(_generator, &"timeline", timeline)
		_undo_redo.add_undo_property(_generator, &"timeline", null)
		_undo_redo.commit_action()
	_status.text = ""
	_refresh()


func _on_play_toggled(pressed: bool) -> void:
	if not pressed:
		_stop()
		return
	_request("play")


func _stop() -> void:
	_playing = false
	if _play_button != null:
		_play_button.set_pressed_no_signal(false)
		_play_button.text = "Play"


func _on_scrubbed(time: float) -> void:
	set_playhead(time)


# Runs `what` now, or once the model has loaded (turning the editor preview on).
func _request(what: String) -> void:
	if _generator == null or _timeline() == null:
		_stop()
		return
	if not _generator.preview_in_editor:
		_generator.preview_in_editor = true
	if _generator.is_model_loaded():
		_run(what)
		return
	_pending = what
	_status.text = "Loading the motion model…"
	if not _generator.model_loaded.is_connected(_on_model_loaded):
		_generator.model_loaded.connect(_on_model_loaded, CONNECT_ONE_SHOT)
	if not _generator.generation_failed.is_connected(_on_load_failed):
		_generator.generation_failed.connect(_on_load_failed, CONNECT_ONE_SHOT)


func _on_model_loaded() -> void:
	if _generator != null and _generator.generation_failed.is_connected(_on_load_failed):
		_generator.generation_failed.disconnect(_on_load_failed)
	var what := _pending
	_pending = ""
	if not what.is_empty():
		_status.text = "Model loaded."
		_run(what)


func _on_load_failed(message: String) -> void:
	if _pending.is_empty():
		return
	_pending = ""
	_stop()
	_status.text = "Model failed to load: %s" % message


func _run(what: String) -> void:
	match what:
		"generate":
			_generate()
		"play":
			if not _generator.has_clip() and not _generate():
				_stop()
				return
			var timeline := _timeline()
			if _playhead >= timeline.length and not timeline.loop:
				_playhead = 0.0
			_playing = true
			_play_button.set_pressed_no_signal(true)
			_play_button.text = "Pause"
		"bake":
			_bake()
		"bvh":
			export_bvh(_pending_path)


func _generate() -> bool:
	var ok := _generator.generate_clip()
	if ok:
		_status.text = "Generated %.2f s of motion." % _generator.get_clip_length()
		_generator.seek_clip(_playhead)
	else:
		_status.text = "Generation failed: %s" % _generator.get_last_error()
	return ok


func _refresh_players() -> void:
	var previous := ""
	if _player_option.selected >= 0:
		previous = str(_player_option.get_item_metadata(_player_option.selected))
	_player_option.clear()
	var root: Node = null
	if Engine.is_editor_hint():
		root = EditorInterface.get_edited_scene_root()
	if root == null:
		_player_option.add_item("(no scene)")
		_player_option.set_item_disabled(0, true)
		return
	var players: Array[Node] = root.find_children("*", "AnimationPlayer", true, false)
	if root is AnimationPlayer:
		players.push_front(root)
	if players.is_empty():
		_player_option.add_item("(no AnimationPlayer)")
		_player_option.set_item_disabled(0, true)
		return
	for player in players:
		var path := str(root.get_path_to(player))
		_player_option.add_item(player.name)
		var index := _player_option.item_count - 1
		_player_option.set_item_metadata(index, path)
		if path == previous:
			_player_option.select(index)


func _selected_player() -> AnimationPlayer:
	if not Engine.is_editor_hint() or _player_option.selected < 0:
		return null
	var root := EditorInterface.get_edited_scene_root()
	if root == null:
		return null
	var path: Variant = _player_option.get_item_metadata(_player_option.selected)
	if path == null:
		return null
	return root.get_node_or_null(NodePath(str(path))) as AnimationPlayer


func _bake() -> void:
	var player := _selected_player()
	if player == null:
		_status.text = "Bake: choose an AnimationPlayer of the edited scene."
		return
	bake_into(player, _animation_edit.text.strip_edges())


## Bakes the timeline into animation `animation_name` of `player`'s default
## library (made when missing), as one undo action; false on failure (see the
## status). Needs the model loaded (the Bake button waits for it).
func bake_into(player: AnimationPlayer, animation_name: String) -> bool:
	if _timeline() == null:
		return false
	if not _is_valid_animation_name(animation_name):
		_status.text = 'Bake: "%s" is not a valid animation name.' % animation_name
		return false
	var root_node := player.get_node_or_null(player.root_node)
	var animation: Animation = _generator.bake_animation(_timeline().length, BAKE_FPS, root_node)
	if animation == null:
		_status.text = "Bake failed: %s" % _generator.get_last_error()
		return false
	var library: AnimationLibrary = null
	if player.has_animation_library(&""):
		library = player.get_animation_library(&"")
	var new_library := library == null
	if new_library:
		library = AnimationLibrary.new()
	if _undo_redo == null:
		if new_library:
			player.add_animation_library(&"", library)
		library.add_animation(animation_name, animation)
	else:
		_undo_redo.create_action("Bake Motion Animation", UndoRedo.MERGE_DISABLE, player)
		if new_library:
			_undo_redo.add_do_method(player, &"add_animation_library", &"", library)
		_undo_redo.add_do_method(library, &"add_animation", animation_name, animation)
		if new_library:
			_undo_redo.add_undo_method(player, &"remove_animation_library", &"")
		elif library.has_animation(animation_name):
			var old := library.get_animation(animation_name)
			_undo_redo.add_undo_method(library, &"add_animation", animation_name, old)
		else:
			_undo_redo.add_undo_method(library, &"remove_animation", animation_name)
		_undo_redo.commit_action()
	_status.text = (
		'Baked "%s" (%.2f s, %d tracks) into %s.'
		% [animation_name, animation.length, animation.get_track_count(), player.name]
	)
	return true


# AnimationLibrary's rule (not exposed to scripts): no "/", ":", "," or "[".
func _is_valid_animation_name(animation_name: String) -> bool:
	if animation_name.is_empty():
		return false
	for character: String in ["/", ":", ",", "["]:
		if animation_name.contains(character):
			return false
	return true


func _open_file_dialog(kind: String) -> void:
	if _timeline() == null:
		return
	_file_kind = kind
	_file_dialog.clear_filters()
	if kind == "bvh":
		_file_dialog.title = "Export BVH"
		_file_dialog.add_filter("*.bvh", "BVH motion")
		_file_dialog.current_file = "motion.bvh"
	else:
		_file_dialog.title = "Export Timeline JSON"
		_file_dialog.add_filter("*.json", "ARDY timeline JSON")
		_file_dialog.current_file = "timeline.json"
	_file_dialog.popup_file_dialog()


func _on_file_selected(path: String) -> void:
	if _generator == null:
		return
	if _file_kind == "bvh":
		_pending_path = path
		_request("bvh")
	else:
		export_json(path)


## Writes the timeline's motion as BVH to `path`; an Error code. Needs the model
## loaded (the Export BVH button waits for it).
func export_bvh(path: String) -> int:
	if _timeline() == null:
		return ERR_UNCONFIGURED
	var error := _generator.export_bvh(path, _timeline().length)
	if error == OK:
		_status.text = "Exported BVH to %s." % path
	else:
		_status.text = (
			"BVH export failed (%s): %s" % [error_string(error), _generator.get_last_error()]
		)
	return error


## Writes the timeline as the JSON of the CLI ardy-generate to `path`; an
## Error code.
func export_json(path: String) -> int:
	if _timeline() == null:
		return ERR_UNCONFIGURED
	var file := FileAccess.open(path, FileAccess.WRITE)
	if file == null:
		var error := FileAccess.get_open_error()
		_status.text = "Cannot write %s: %s" % [path, error_string(error)]
		return error
	file.store_string(_generator.timeline_to_json())
	file.close()
	_status.text = "Exported the timeline to %s." % path
	return OK


# One undo action from properties changed already: `changes` holds their
# values from before ({"object", "property", "value"}); the new ones are read
# from the objects.
func _commit_changes(action_name: String, changes: Array[Dictionary]) -> void:
	var changed := false
	for change in changes:
		var object: Object = change["object"]
		if object.get(change["property"]) != change["value"]:
			changed = true
	if not changed:
		return
	_mark_edited()
	if _undo_redo == null:
		return
	_undo_redo.create_action(action_name)
	for change in changes:
		var object: Object = change["object"]
		var property: StringName = change["property"]
		_undo_redo.add_do_property(object, property, object.get(property))
		_undo_redo.add_undo_property(object, property, change["value"])
	_undo_redo.commit_action()


# Replaces the array `track` of the timeline by `items`, as an undo action.
func _set_items(action_name: String, track: String, items: Array) -> void:
	var timeline := _timeline()
	var old_items: Array = track_view.get_items(track).duplicate()
	_mark_edited()
	if _undo_redo == null:
		timeline.set(track, items)
		return
	_undo_redo.create_action(action_name)
	_undo_redo.add_do_property(timeline, track, items)
	_undo_redo.add_undo_property(timeline, track, old_items)
	_undo_redo.commit_action()


func _mark_edited() -> void:
	if _generator != null and _generator.has_clip():
		_status.text = "Timeline edited: press Generate to update the preview."
	track_view.queue_redraw()


func _item_name(track: String) -> String:
	return TrackView.ITEM_NAMES[maxi(TrackView.TRACKS.find(track), 0)]


func _make_item(track: String, time: float) -> Resource:
	match track:
		"prompts":
			var prompt := MotionPrompt.new()
			prompt.time = time
			prompt.text = DEFAULT_PROMPT
			return prompt
		"waypoints":
			var waypoint := MotionWaypoint.new()
			waypoint.time = time
			waypoint.position = _origin().origin + _forward()
			return waypoint
		"paths":
			var path := MotionPath.new()
			path.start_time = time
			var start := _origin().origin
			path.points = PackedVector3Array([start, start + _forward() * PATH_LENGTH])
			return path
		"keyframes":
			var keyframe := MotionKeyframe.new()
			keyframe.time = time
			keyframe.pose = _current_pose()
			return keyframe
		"joint_targets":
			var target := MotionJointTarget.new()
			target.time = time
			target.bone = JOINT_TARGET_BONE
			target.use_position = true
			target.position = _hand_position()
			return target
	var contact := MotionContact.new()
	contact.start_time = time
	contact.end_time = time + CONTACT_SECONDS
	contact.feet = 0
	contact.planted = true
	return contact


# The generator's world transform (its local one outside a scene tree).
func _origin() -> Transform3D:
	if _generator.is_inside_tree():
		return _generator.global_transform
	return _generator.transform


# The generator's forward (+Z) on the ground, one metre long.
func _forward() -> Vector3:
	var forward := _origin().basis.z
	forward.y = 0.0
	if forward.length_squared() < 1e-6:
		return Vector3.BACK
	return forward.normalized()


func _skeleton() -> Skeleton3D:
	if _generator.skeleton.is_empty():
		return null
	return _generator.get_node_or_null(_generator.skeleton) as Skeleton3D


# Bone name -> local pose rotation of every bone of the skeleton, as now.
func _current_pose() -> Dictionary:
	var pose: Dictionary = {}
	var skeleton := _skeleton()
	if skeleton == null:
		return pose
	for bone in skeleton.get_bone_count():
		pose[skeleton.get_bone_name(bone)] = skeleton.get_bone_pose_rotation(bone)
	return pose


# The world position of the skeleton's right hand (else a metre up and ahead).
func _hand_position() -> Vector3:
	var fallback := _origin().origin + Vector3.UP + _forward() * 0.4
	var skeleton := _skeleton()
	if skeleton == null or not skeleton.is_inside_tree():
		return fallback
	var bone := skeleton.find_bone(JOINT_TARGET_BONE)
	if bone < 0:
		for i in skeleton.get_bone_count():
			var bone_name := skeleton.get_bone_name(i).to_lower()
			if bone_name.contains("right") and bone_name.contains("hand"):
				bone = i
				break
	if bone < 0:
		return fallback
	return skeleton.global_transform * skeleton.get_bone_global_pose(bone).origin
