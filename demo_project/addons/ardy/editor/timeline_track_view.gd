@tool
extends Control
## The track area of the "Motion Timeline" panel: a time ruler and one row per
## kind of timeline item (prompts, waypoints, paths, keyframes, joint targets,
## contacts). Draws the items of `timeline`, lets the mouse drag them in time,
## resize blocks by their right edge, scrub the playhead on the ruler, and asks
## (through its signals) for items to be added, removed or edited. It changes
## item properties only while a drag previews; the owner makes the undo action
## from `drag_finished`.

## The ruler was clicked or dragged at `time` (seconds).
signal scrubbed(time: float)
## A drag ended; `changes` holds {"object", "property", "value"} with the
## values from before the drag (the new ones are on the objects).
signal drag_finished(action_name: String, changes: Array[Dictionary])
## "Add <kind> here" was chosen on the row of `track` at `time`.
signal add_requested(track: String, time: float)
## "Remove" was chosen on an item.
signal remove_requested(track: String, index: int)
## A prompt block was double-clicked.
signal prompt_edit_requested(index: int)

## The timeline's array properties, one row each, top to bottom.
const TRACKS: Array[String] = [
	"prompts", "waypoints", "paths", "keyframes", "joint_targets", "contacts"
]
const TRACK_LABELS: Array[String] = [
	"Prompts", "Waypoints", "Paths", "Keyframes", "Joint targets", "Contacts"
]
## The item name of each track, for menus and undo action names.
const ITEM_NAMES: Array[String] = [
	"Prompt", "Waypoint", "Path", "Keyframe", "Joint Target", "Contact"
]
const TRACK_COLORS: Array[Color] = [
	Color(0.36, 0.62, 0.38),
	Color(0.93, 0.62, 0.26),
	Color(0.35, 0.58, 0.86),
	Color(0.78, 0.45, 0.82),
	Color(0.90, 0.40, 0.40),
	Color(0.45, 0.75, 0.75),
]
const BLOCK_TRACKS: Array[String] = ["prompts", "paths", "contacts"]
const RULER_HEIGHT := 24.0
const ROW_HEIGHT := 28.0
const HEADER_WIDTH := 110.0
const DIAMOND_RADIUS := 7.0
## Pixels from a block's right edge that grab the edge instead of the block.
const EDGE_PIXELS := 5.0
const SNAP_SECONDS := 0.1
const MIN_SECONDS := 0.1
const MIN_PIXELS_PER_SECOND := 10.0
const MAX_PIXELS_PER_SECOND := 2000.0
const ZOOM_STEP := 1.2
## Seconds scrolled per wheel step, in pixels (converted with the zoom).
const SCROLL_PIXELS := 60.0
## Labelled ruler ticks are at least this many pixels apart.
const LABEL_SPACING := 60.0
const TICK_STEPS: Array[float] = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 15.0, 30.0, 60.0]
const MENU_ADD := 0
const MENU_REMOVE := 1

var timeline: MotionTimeline:
	set(value):
		timeline = value
		_cancel_drag()
		queue_redraw()
## The playhead, seconds.
var playhead := 0.0:
	set(value):
		playhead = value
		queue_redraw()
var pixels_per_second := 80.0
## The time at the left edge of the track area.
var scroll_seconds := 0.0

var _menu: PopupMenu
var _menu_track := ""
var _menu_index := -1
var _menu_time := 0.0
var _scrubbing := false
## The drag under way: {"track", "index", "edge", "grab_time", "start", "changes"}.
var _drag: Dictionary = {}
## The hash of what the last _draw() showed (see _state_hash()).
var _drawn_state := 0


func _init() -> void:
	custom_minimum_size = Vector2(0, RULER_HEIGHT + ROW_HEIGHT * TRACKS.size())
	mouse_filter = MOUSE_FILTER_STOP
	focus_mode = FOCUS_CLICK
	clip_contents = true


func _ready() -> void:
	_menu = PopupMenu.new()
	_menu.id_pressed.connect(_on_menu_id_pressed)
	add_child(_menu)


## The item under `position` (local pixels) as {"track": String, "index": int},
## or an empty Dictionary.
func item_at(point: Vector2) -> Dictionary:
	var hit := _hit(point)
	if hit.is_empty():
		return {}
	return {"track": hit["track"], "index": hit["index"]}


## The x (local pixels) of `time` seconds.
func time_to_x(time: float) -> float:
	return HEADER_WIDTH + (time - scroll_seconds) * pixels_per_second


## The time (seconds) at x (local pixels).
func x_to_time(x: float) -> float:
	return scroll_seconds + (x - HEADER_WIDTH) / pixels_per_second


## The vertical middle (local pixels) of the row of `track`.
func row_center(track: String) -> float:
	return RULER_HEIGHT + ROW_HEIGHT * (TRACKS.find(track) + 0.5)


## The items of `track` (the timeline's array, not a copy; do not change it).
func get_items(track: String) -> Array:
	if timeline == null or not TRACKS.has(track):
		return []
	var items: Array = timeline.get(track)
	return items


## The start and end (seconds) of an item; both the same for point items.
func item_span(track: String, index: int) -> Vector2:
	var items := get_items(track)
	if index < 0 or index >= items.size():
		return Vector2.ZERO
	match track:
		"prompts":
			var prompt: MotionPrompt = items[index]
			var next := next_prompt(index)
			var end: float = timeline.length
			if next >= 0:
				var next_prompt_item: MotionPrompt = items[next]
				end = next_prompt_item.time
			return Vector2(prompt.time, maxf(end, prompt.time))
		"paths":
			var path: MotionPath = items[index]
			return Vector2(path.start_time, path.start_time + path.get_duration())
		"contacts":
			var contact: MotionContact = items[index]
			return Vector2(contact.start_time, contact.end_time)
	var time: float = _item_resource(track, index).get("time")
	return Vector2(time, time)


## The prompt that follows prompt `index` in time (-1 for the last one).
func next_prompt(index: int) -> int:
	var prompts := get_items("prompts")
	var own: MotionPrompt = prompts[index]
	var best := -1
	var best_time := INF
	for i in prompts.size():
		if i == index:
			continue
		var other: MotionPrompt = prompts[i]
		var later := other.time > own.time or (other.time == own.time and i > index)
		if later and other.time < best_time:
			best = i
			best_time = other.time
	return best


## The properties a move (edge false) or a resize (edge true) of an item
## changes, with their values now: {"object", "property", "value"} each.
func capture(track: String, index: int, edge: bool) -> Array[Dictionary]:
	var changes: Array[Dictionary] = []
	var item := _item_resource(track, index)
	if item == null:
		return changes
	var properties: Array[StringName] = []
	if edge:
		match track:
			"contacts":
				properties = [&"end_time"]
			"paths":
				properties = [&"speed"]
			"prompts":
				var next := next_prompt(index)
				if next < 0:
					return changes
				item = _item_resource(track, next)
				properties = [&"time"]
	else:
		match track:
			"paths":
				properties = [&"start_time"]
			"contacts":
				properties = [&"start_time", &"end_time"]
			_:
				properties = [&"time"]
	for property in properties:
		changes.append({"object": item, "property": property, "value": item.get(property)})
	return changes


## Moves an item so that it starts at `time` (a contact keeps its length).
func apply_move(track: String, index: int, time: float) -> void:
	var item := _item_resource(track, index)
	if item == null:
		return
	var start := clampf(time, 0.0, maxf(timeline.length, 0.0))
	match track:
		"paths":
			item.set(&"start_time", start)
		"contacts":
			var contact := item as MotionContact
			var length := contact.end_time - contact.start_time
			contact.start_time = start
			contact.end_time = start + length
		_:
			item.set(&"time", start)


## Moves the right edge of a block to `time`: a contact's end, a path's speed
## (so that its duration matches), a prompt's next prompt.
func apply_resize(track: String, index: int, time: float) -> void:
	var item := _item_resource(track, index)
	if item == null:
		return
	match track:
		"contacts":
			var contact := item as MotionContact
			contact.end_time = maxf(time, contact.start_time + MIN_SECONDS)
		"paths":
			var path := item as MotionPath
			var distance := polyline_length(path.points)
			if distance > 0.0:
				path.speed = distance / maxf(time - path.start_time, MIN_SECONDS)
		"prompts":
			var next := next_prompt(index)
			if next < 0:
				return
			var prompt := item as MotionPrompt
			var following := next_prompt(next)
			var upper: float = timeline.length
			if following >= 0:
				upper = (_item_resource(track, following) as MotionPrompt).time
			var next_item := _item_resource(track, next) as MotionPrompt
			next_item.time = clampf(time, prompt.time + MIN_SECONDS, maxf(upper, prompt.time))


## The length (metres) of a polyline.
static func polyline_length(points: PackedVector3Array) -> float:
	var total := 0.0
	for i in range(1, points.size()):
		total += points[i - 1].distance_to(points[i])
	return total


func _process(_delta: float) -> void:
	# Items also change in the inspector and by undo: redraw when what would
	# be drawn changed (not every frame, which would keep the editor busy).
	if is_visible_in_tree() and _state_hash() != _drawn_state:
		queue_redraw()


func _gui_input(event: InputEvent) -> void:
	var button := event as InputEventMouseButton
	if button != null:
		_on_mouse_button(button)
		return
	var motion := event as InputEventMouseMotion
	if motion != null:
		_on_mouse_motion(motion)


func _on_mouse_button(event: InputEventMouseButton) -> void:
	if event.pressed and _is_wheel(event.button_index):
		_on_wheel(event)
		accept_event()
		return
	if event.button_index == MOUSE_BUTTON_LEFT:
		if event.pressed:
			_on_left_press(event)
		else:
			_scrubbing = false
			_finish_drag()
		accept_event()
	elif event.button_index == MOUSE_BUTTON_RIGHT and event.pressed:
		_cancel_drag()
		_open_menu(event.position)
		accept_event()


func _on_left_press(event: InputEventMouseButton) -> void:
	if event.position.y < RULER_HEIGHT:
		if event.position.x >= HEADER_WIDTH:
			_scrubbing = true
			_scrub(event.position.x)
		return
	var hit := _hit(event.position)
	if hit.is_empty():
		return
	var track: String = hit["track"]
	var index: int = hit["index"]
	if event.double_click:
		_cancel_drag()
		if track == "prompts":
			prompt_edit_requested.emit(index)
		return
	var edge: bool = hit["edge"]
	var span := item_span(track, index)
	_drag = {
		"track": track,
		"index": index,
		"edge": edge,
		"grab_time": x_to_time(event.position.x),
		"start": span.y if edge else span.x,
		"changes": capture(track, index, edge),
	}


func _on_mouse_motion(event: InputEventMouseMotion) -> void:
	if _scrubbing:
		_scrub(event.position.x)
		return
	if _drag.is_empty():
		_update_cursor(event.position)
		return
	var track: String = _drag["track"]
	var index: int = _drag["index"]
	var grab_time: float = _drag["grab_time"]
	var start: float = _drag["start"]
	var time := start + x_to_time(event.position.x) - grab_time
	if not event.shift_pressed:
		time = snappedf(time, SNAP_SECONDS)
	if _drag["edge"]:
		apply_resize(track, index, time)
	else:
		apply_move(track, index, time)
	queue_redraw()


func _finish_drag() -> void:
	if _drag.is_empty():
		return
	var kind := ITEM_NAMES[TRACKS.find(_drag["track"])]
	var verb := "Resize" if _drag["edge"] else "Move"
	var changes: Array[Dictionary] = _drag["changes"]
	_drag = {}
	drag_finished.emit("%s %s" % [verb, kind], changes)
	queue_redraw()


## Puts the dragged item back as it was (a drag that is abandoned).
func _cancel_drag() -> void:
	if _drag.is_empty():
		return
	var changes: Array[Dictionary] = _drag["changes"]
	_drag = {}
	for change in changes:
		var object: Object = change["object"]
		object.set(change["property"], change["value"])


func _scrub(x: float) -> void:
	var time := maxf(x_to_time(x), 0.0)
	if timeline != null:
		time = minf(time, timeline.length)
	scrubbed.emit(time)


func _on_wheel(event: InputEventMouseButton) -> void:
	var direction := (
		-1.0 if event.button_index in [MOUSE_BUTTON_WHEEL_UP, MOUSE_BUTTON_WHEEL_LEFT] else 1.0
	)
	if event.ctrl_pressed or event.meta_pressed:
		# Zoom about the time under the pointer.
		var anchor := x_to_time(event.position.x)
		var factor := ZOOM_STEP if direction < 0.0 else 1.0 / ZOOM_STEP
		pixels_per_second = clampf(
			pixels_per_second * factor, MIN_PIXELS_PER_SECOND, MAX_PIXELS_PER_SECOND
		)
		scroll_seconds = anchor - (event.position.x - HEADER_WIDTH) / pixels_per_second
	else:
		scroll_seconds += direction * SCROLL_PIXELS / pixels_per_second
	scroll_seconds = clampf(scroll_seconds, 0.0, maxf(_length() - 1.0, 0.0))
	queue_redraw()


func _is_wheel(button_index: MouseButton) -> bool:
	return (
		button_index
		in [
			MOUSE_BUTTON_WHEEL_UP,
			MOUSE_BUTTON_WHEEL_DOWN,
			MOUSE_BUTTON_WHEEL_LEFT,
			MOUSE_BUTTON_WHEEL_RIGHT
		]
	)


func _update_cursor(point: Vector2) -> void:
	var hit := _hit(point)
	if hit.is_empty():
		mouse_default_cursor_shape = CURSOR_ARROW
	elif hit["edge"]:
		mouse_default_cursor_shape = CURSOR_HSIZE
	else:
		mouse_default_cursor_shape = CURSOR_MOVE


func _open_menu(point: Vector2) -> void:
	var row := _row_at(point.y)
	if row < 0 or point.x < HEADER_WIDTH or timeline == null:
		return
	_menu.clear()
	var hit := _hit(point)
	_menu_track = TRACKS[row]
	_menu_time = maxf(snappedf(x_to_time(point.x), SNAP_SECONDS), 0.0)
	if hit.is_empty():
		_menu_index = -1
		_menu.add_item("Add %s here" % ITEM_NAMES[row].to_lower(), MENU_ADD)
	else:
		_menu_track = hit["track"]
		_menu_index = hit["index"]
		_menu.add_item("Remove", MENU_REMOVE)
	_menu.reset_size()
	_menu.position = Vector2i(get_screen_position() + point)
	_menu.popup()


func _on_menu_id_pressed(id: int) -> void:
	if id == MENU_ADD:
		add_requested.emit(_menu_track, _menu_time)
	elif id == MENU_REMOVE:
		remove_requested.emit(_menu_track, _menu_index)


## The item under `position` with "edge" (true on a block's right edge).
func _hit(point: Vector2) -> Dictionary:
	var row := _row_at(point.y)
	if row < 0 or point.x < HEADER_WIDTH or timeline == null:
		return {}
	var track := TRACKS[row]
	# The last drawn is on top: search from the end.
	var order: Array = range(get_items(track).size() - 1, -1, -1)
	if not BLOCK_TRACKS.has(track):
		for index: int in order:
			if absf(point.x - time_to_x(item_span(track, index).x)) <= DIAMOND_RADIUS:
				return {"track": track, "index": index, "edge": false}
		return {}
	# Right edges first: a prompt's edge is where the next prompt starts.
	for index: int in order:
		var resizable := track != "prompts" or next_prompt(index) >= 0
		if resizable and absf(point.x - time_to_x(item_span(track, index).y)) <= EDGE_PIXELS:
			return {"track": track, "index": index, "edge": true}
	for index: int in order:
		var span := item_span(track, index)
		if point.x >= time_to_x(span.x) and point.x <= time_to_x(span.y):
			return {"track": track, "index": index, "edge": false}
	return {}


func _row_at(y: float) -> int:
	if y < RULER_HEIGHT:
		return -1
	var row := floori((y - RULER_HEIGHT) / ROW_HEIGHT)
	return row if row < TRACKS.size() else -1


func _item_resource(track: String, index: int) -> Resource:
	var items := get_items(track)
	if index < 0 or index >= items.size():
		return null
	var item: Resource = items[index]
	return item


func _length() -> float:
	return timeline.length if timeline != null else 10.0


# A hash of everything _draw() shows.
func _state_hash() -> int:
	var state: Array = [playhead, pixels_per_second, scroll_seconds, size, _drag.get("index", -1)]
	if timeline != null:
		state.append(timeline.length)
		for track in TRACKS:
			for index in get_items(track).size():
				state.append(item_span(track, index))
				state.append(_block_text(track, index))
	return state.hash()


func _draw() -> void:
	_drawn_state = _state_hash()
	var font := get_theme_default_font()
	var font_size := get_theme_default_font_size()
	draw_rect(Rect2(Vector2.ZERO, size), Color(0.11, 0.12, 0.14))
	for row in TRACKS.size():
		var y := RULER_HEIGHT + ROW_HEIGHT * row
		if row % 2 == 1:
			draw_rect(Rect2(0, y, size.x, ROW_HEIGHT), Color(1, 1, 1, 0.03))
		draw_line(Vector2(0, y), Vector2(size.x, y), Color(1, 1, 1, 0.08))
	# Past the timeline's end is shaded.
	var end_x := time_to_x(_length())
	if end_x < size.x:
		draw_rect(Rect2(end_x, RULER_HEIGHT, size.x - end_x, size.y), Color(0, 0, 0, 0.3))
	if timeline != null:
		for row in TRACKS.size():
			_draw_track(row, font, font_size)
	_draw_ruler(font, font_size)
	var x := time_to_x(playhead)
	if x >= HEADER_WIDTH:
		draw_line(Vector2(x, 0), Vector2(x, size.y), Color(1, 0.3, 0.3), 2.0)
	# The row names, over anything scrolled under them.
	draw_rect(Rect2(0, 0, HEADER_WIDTH, size.y), Color(0.15, 0.16, 0.19))
	for row in TRACKS.size():
		var y := RULER_HEIGHT + ROW_HEIGHT * (row + 0.5) + font_size * 0.35
		draw_string(
			font, Vector2(8, y), TRACK_LABELS[row], HORIZONTAL_ALIGNMENT_LEFT, -1, font_size
		)
	if timeline == null:
		draw_string(
			font,
			Vector2(HEADER_WIDTH + 12, RULER_HEIGHT + ROW_HEIGHT * 0.6),
			"No timeline",
			HORIZONTAL_ALIGNMENT_LEFT,
			-1,
			font_size,
			Color(1, 1, 1, 0.5)
		)


func _draw_ruler(font: Font, font_size: int) -> void:
	draw_rect(Rect2(0, 0, size.x, RULER_HEIGHT), Color(0.17, 0.18, 0.21))
	var step: float = TICK_STEPS[TICK_STEPS.size() - 1]
	for candidate in TICK_STEPS:
		if candidate * pixels_per_second >= LABEL_SPACING:
			step = candidate
			break
	var minor := step / 5.0
	var first := floori(scroll_seconds / minor)
	var last := ceili(x_to_time(size.x) / minor)
	for i in range(maxi(first, 0), last + 1):
		var time := i * minor
		var x := time_to_x(time)
		if x < HEADER_WIDTH:
			continue
		if i % 5 == 0:
			draw_line(Vector2(x, RULER_HEIGHT - 10), Vector2(x, RULER_HEIGHT), Color(1, 1, 1, 0.6))
			var label := ("%.1f" % time) if step < 1.0 else ("%d" % roundi(time))
			draw_string(
				font,
				Vector2(x + 3, RULER_HEIGHT - 9),
				label,
				HORIZONTAL_ALIGNMENT_LEFT,
				-1,
				font_size - 2,
				Color(1, 1, 1, 0.7)
			)
		else:
			draw_line(Vector2(x, RULER_HEIGHT - 4), Vector2(x, RULER_HEIGHT), Color(1, 1, 1, 0.3))
	draw_line(Vector2(0, RULER_HEIGHT), Vector2(size.x, RULER_HEIGHT), Color(1, 1, 1, 0.25))


func _draw_track(row: int, font: Font, font_size: int) -> void:
	var track := TRACKS[row]
	var color := TRACK_COLORS[row]
	var y := RULER_HEIGHT + ROW_HEIGHT * row
	var items := get_items(track)
	for index in items.size():
		var span := item_span(track, index)
		var x0 := time_to_x(span.x)
		var dragged: bool = (
			not _drag.is_empty() and _drag["track"] == track and _drag["index"] == index
		)
		var fill := color.lightened(0.25) if dragged else color
		if not BLOCK_TRACKS.has(track):
			_draw_diamond(Vector2(x0, y + ROW_HEIGHT * 0.5), fill)
			continue
		var x1 := maxf(time_to_x(span.y), x0 + 2.0)
		var box := Rect2(x0, y + 3, x1 - x0, ROW_HEIGHT - 6)
		draw_rect(box, Color(fill, 0.75))
		draw_rect(box, fill.lightened(0.3), false, 1.0)
		var text := _block_text(track, index)
		var room := box.size.x - 8.0
		if not text.is_empty() and room > 8.0:
			draw_string(
				font,
				Vector2(x0 + 4, y + ROW_HEIGHT * 0.5 + font_size * 0.35),
				_fit(font, font_size, text, room),
				HORIZONTAL_ALIGNMENT_LEFT,
				-1,
				font_size
			)


func _block_text(track: String, index: int) -> String:
	var item := _item_resource(track, index)
	match track:
		"prompts":
			var text := (item as MotionPrompt).text
			return text if not text.is_empty() else "(no prompt)"
		"paths":
			return "%.1f m/s" % (item as MotionPath).speed
		"contacts":
			var contact := item as MotionContact
			var feet: String = ["both feet", "left foot", "right foot"][clampi(contact.feet, 0, 2)]
			return ("%s planted" if contact.planted else "%s lifted") % feet
	return ""


func _draw_diamond(center: Vector2, color: Color) -> void:
	var r := DIAMOND_RADIUS
	var points := PackedVector2Array(
		[
			center + Vector2(0, -r),
			center + Vector2(r, 0),
			center + Vector2(0, r),
			center + Vector2(-r, 0)
		]
	)
	draw_colored_polygon(points, color)
	points.append(points[0])
	draw_polyline(points, color.lightened(0.4), 1.0)


## `text` cut with an ellipsis to fit `width` pixels.
func _fit(font: Font, font_size: int, text: String, width: float) -> String:
	if font.get_string_size(text, HORIZONTAL_ALIGNMENT_LEFT, -1, font_size).x <= width:
		return text
	var cut := text
	while cut.length() > 0:
		cut = cut.left(cut.length() - 1)
		var candidate := cut + "…"
		if font.get_string_size(candidate, HORIZONTAL_ALIGNMENT_LEFT, -1, font_size).x <= width:
			return candidate
	return ""
