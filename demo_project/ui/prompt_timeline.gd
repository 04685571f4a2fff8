class_name PromptTimeline
extends Control
## A strip that shows the generator's motion clock as a track scrolling under a
## fixed "now" line: the last seconds and the ones to come, the prompt playing
## (from when it started), the prompts queued through this strip, and the
## waypoints and keyframes at their times. Placed at the bottom of the screen,
## full width, unless anchors and offsets are set after new().

const HEIGHT := 70.0
const PAST_SECONDS := 2.0
const FUTURE_SECONDS := 8.0
const PADDING := 10.0
## Pixels between second ticks below which only every other one is labelled.
const LABEL_SPACING := 56.0
const PROMPT_LANE := Rect2(0, 6, 0, 20)
const GOAL_Y := 37.0
const AXIS_Y := 49.0
const TICK_LABEL_Y := 64.0
const MARK_RADIUS := 6.0
## Pixels from a mark within which the pointer shows that mark's tooltip.
const HOVER_PIXELS := 8.0
const LEGEND := (
	"Motion clock, 2 s back and 8 s ahead of the white line.\n"
	+ "Top: prompts (green: playing, orange: queued). Middle: waypoints (diamonds)\n"
	+ "and keyframes (squares), faded once reached. Green line: motion generated ahead."
)

var generator: MotionGenerator
var _schedule := PromptSchedule.new()
var _reached: Dictionary = {}
var _last_time := 0.0
var _refused := false
var _font: Font


func _init() -> void:
	anchor_left = 0.0
	anchor_right = 1.0
	anchor_top = 1.0
	anchor_bottom = 1.0
	offset_left = UiStyle.MARGIN
	offset_right = -UiStyle.MARGIN
	offset_top = -HEIGHT - UiStyle.MARGIN
	offset_bottom = -UiStyle.MARGIN
	custom_minimum_size = Vector2(0, HEIGHT)
	# Clicks on the strip are the strip's: they must not place a waypoint on
	# the ground behind it.
	mouse_filter = MOUSE_FILTER_STOP
	tooltip_text = LEGEND


func _ready() -> void:
	_font = get_theme_default_font()
	if generator == null:
		return
	generator.prompt_started.connect(_on_prompt_started)
	generator.waypoint_reached.connect(func(index: int) -> void: _reached[index] = true)
	generator.generation_failed.connect(func(_message: String) -> void: _refused = true)


## Makes `text` the prompt `in_seconds` from now on the motion clock, and shows
## it on the track until it starts.
func queue_prompt(text: String, in_seconds: float) -> void:
	var clean := text.strip_edges()
	if generator == null or clean.is_empty():
		return
	var at := generator.get_time() + maxf(in_seconds, 0.0)
	# The node reports a refused prompt (too long, bad time) only through its
	# signal, emitted during the call.
	_refused = false
	generator.queue_prompt(clean, at)
	if _refused:
		return
	_schedule.add_queued(clean, at)
	queue_redraw()


## Removes the prompt and every queued one, on the generator and the track.
func clear_prompts() -> void:
	if generator != null:
		generator.clear_prompts()
	_schedule.clear()
	queue_redraw()


## The prompts this strip queued that have not started, soonest first, as
## {"text": String, "time": float} (motion clock seconds).
func get_queued() -> Array[Dictionary]:
	return _schedule.queued.duplicate(true)


func _process(_delta: float) -> void:
	var now := _now()
	if now + 0.05 < _last_time:
		# The clock went back: reset() restarted the motion and dropped its
		# queued prompts and goals.
		_schedule.clear()
		_reached.clear()
	_last_time = now
	_schedule.prune(now, now - PAST_SECONDS)
	if generator != null and generator.get_waypoints().size() < _reached.size():
		_reached.clear()  # the waypoints were cleared and placed again
	queue_redraw()


func _draw() -> void:
	draw_style_box(UiStyle.panel(), Rect2(Vector2.ZERO, size))
	var now := _now()
	var x_now := _x(now, now)
	# The past is shaded: what is left of the line has been shown.
	draw_rect(Rect2(PADDING, 1, x_now - PADDING, size.y - 2), Color(0, 0, 0, 0.22))
	_draw_axis(now)
	# Under the prompts, so their names stay readable where the line crosses.
	draw_line(Vector2(x_now, 3), Vector2(x_now, size.y - 3), UiStyle.TEXT, 2.0)
	_draw_prompts(now)
	_draw_goals(now)
	var clock := "%.1f s" % now
	var clock_size := _font.get_string_size(clock, HORIZONTAL_ALIGNMENT_LEFT, -1, UiStyle.FONT_SIZE)
	var clock_box := Rect2(x_now - clock_size.x / 2 - 4, TICK_LABEL_Y - 13, clock_size.x + 8, 17)
	draw_rect(clock_box, Color(0.06, 0.07, 0.09, 0.95))
	draw_string(
		_font,
		Vector2(clock_box.position.x + 4, TICK_LABEL_Y),
		clock,
		HORIZONTAL_ALIGNMENT_LEFT,
		-1,
		UiStyle.FONT_SIZE,
		UiStyle.TEXT
	)


# Second ticks with their clock times, and how far motion is generated ahead.
func _draw_axis(now: float) -> void:
	var left := PADDING
	var right := size.x - PADDING
	draw_line(Vector2(left, AXIS_Y), Vector2(right, AXIS_Y), Color(1, 1, 1, 0.25), 1.0)
	if generator != null and generator.is_generating():
		var ahead: float = generator.get_stats().get("buffered_seconds", 0.0)
		var end := minf(_x(now + ahead, now), right)
		draw_line(Vector2(_x(now, now), AXIS_Y), Vector2(end, AXIS_Y), UiStyle.ACTIVE_PROMPT, 3.0)
	var every := 1 if _pixels_per_second() >= LABEL_SPACING else 2
	var x_now := _x(now, now)
	for second in range(ceili(now - PAST_SECONDS), floori(now + FUTURE_SECONDS) + 1):
		if second < 0:
			continue
		var x := _x(second, now)
		draw_line(Vector2(x, AXIS_Y - 3), Vector2(x, AXIS_Y + 3), Color(1, 1, 1, 0.5), 1.0)
		# The clock's own label sits on the now line; ticks under it stay bare,
		# and so do those whose label would stick out of the strip.
		var clipped := x - 16.0 < PADDING or x + 16.0 > size.x - PADDING
		if second % every != 0 or absf(x - x_now) < 30.0 or clipped:
			continue
		draw_string(
			_font,
			Vector2(x - 20, TICK_LABEL_Y),
			"%d s" % second,
			HORIZONTAL_ALIGNMENT_CENTER,
			40,
			UiStyle.SMALL_FONT_SIZE,
			UiStyle.DIM_TEXT
		)


# Each prompt as a span from its start to the next one's: the one playing
# bright, earlier ones faded, queued ones in their own colour with a mark down
# to the axis at their time.
func _draw_prompts(now: float) -> void:
	var spans := _schedule.spans()
	for i in spans.size():
		var span := spans[i]
		var state: PromptSchedule.State = span["state"]
		var start := maxf(_x(span["time"], now), PADDING)
		var end := size.x - PADDING
		if i + 1 < spans.size():
			end = minf(_x(spans[i + 1]["time"], now), end)
		if end - start < 1.0:
			continue
		var queued := state == PromptSchedule.State.QUEUED
		var color: Color = UiStyle.QUEUED_PROMPT if queued else UiStyle.ACTIVE_PROMPT
		var fill := {
			PromptSchedule.State.PLAYED: 0.12,
			PromptSchedule.State.PLAYING: 0.3,
			PromptSchedule.State.QUEUED: 0.16,
		}
		var lane := Rect2(start, PROMPT_LANE.position.y, end - start, PROMPT_LANE.size.y)
		draw_rect(lane, Color(color, fill[state]))
		var text_color := UiStyle.TEXT
		if queued:
			var x := _x(span["time"], now)
			draw_line(Vector2(x, lane.position.y), Vector2(x, AXIS_Y), color, 2.0)
			var flag := [Vector2(x - 5, AXIS_Y), Vector2(x + 5, AXIS_Y), Vector2(x, AXIS_Y - 6)]
			draw_colored_polygon(PackedVector2Array(flag), color)
			text_color = color.lightened(0.35)
		else:
			draw_rect(Rect2(start, lane.position.y, 3, lane.size.y), Color(color, fill[state] * 3))
			if state == PromptSchedule.State.PLAYED:
				text_color = UiStyle.DIM_TEXT
		var text := _fit(span["text"], lane.size.x - 12.0)
		if not text.is_empty():
			draw_string(
				_font,
				Vector2(start + 8, lane.position.y + 15),
				text,
				HORIZONTAL_ALIGNMENT_LEFT,
				-1,
				UiStyle.FONT_SIZE,
				text_color
			)


# Waypoints as diamonds, keyframes as squares; reached ones dimmed, and a count
# of those beyond the right edge.
func _draw_goals(now: float) -> void:
	if generator == null:
		return
	var beyond := 0
	var waypoints := generator.get_waypoints()
	for index in waypoints.size():
		var waypoint := waypoints[index] as MotionWaypoint
		if waypoint == null or waypoint.time < now - PAST_SECONDS:
			continue
		if waypoint.time > now + FUTURE_SECONDS:
			beyond += 1
			continue
		var c := Vector2(_x(waypoint.time, now), GOAL_Y)
		var r := MARK_RADIUS
		var diamond := PackedVector2Array(
			[c + Vector2(0, -r), c + Vector2(r, 0), c + Vector2(0, r), c + Vector2(-r, 0)]
		)
		var reached: bool = _reached.has(index)
		draw_colored_polygon(diamond, Color(UiStyle.WAYPOINT, 0.35 if reached else 1.0))
		diamond.append(diamond[0])
		draw_polyline(diamond, Color(1, 1, 1, 0.3 if reached else 0.9), 1.0)
	var keyframes := generator.get_keyframes()
	for keyframe_variant in keyframes:
		var keyframe := keyframe_variant as MotionKeyframe
		if keyframe == null or keyframe.time < now - PAST_SECONDS:
			continue
		if keyframe.time > now + FUTURE_SECONDS:
			beyond += 1
			continue
		var square := Rect2(_x(keyframe.time, now) - 5, GOAL_Y - 5, 10, 10)
		var passed := keyframe.time <= now
		draw_rect(square, Color(UiStyle.KEYFRAME, 0.35 if passed else 1.0))
		draw_rect(square, Color(1, 1, 1, 0.3 if passed else 0.9), false, 1.0)
	if beyond > 0:
		draw_string(
			_font,
			Vector2(size.x - PADDING - 60, GOAL_Y + 5),
			"+%d later" % beyond,
			HORIZONTAL_ALIGNMENT_RIGHT,
			60,
			UiStyle.SMALL_FONT_SIZE,
			UiStyle.DIM_TEXT
		)


# The mark or prompt under the pointer, or the legend.
func _get_tooltip(at_position: Vector2) -> String:
	var now := _now()
	if generator != null and absf(at_position.y - GOAL_Y) <= HOVER_PIXELS:
		var waypoints := generator.get_waypoints()
		for index in waypoints.size():
			var waypoint := waypoints[index] as MotionWaypoint
			if waypoint != null and absf(_x(waypoint.time, now) - at_position.x) <= HOVER_PIXELS:
				var reached := " (reached)" if _reached.has(index) else ""
				return "Waypoint %d at %.1f s%s" % [index, waypoint.time, reached]
		var keyframes := generator.get_keyframes()
		for index in keyframes.size():
			var keyframe := keyframes[index] as MotionKeyframe
			if keyframe != null and absf(_x(keyframe.time, now) - at_position.x) <= HOVER_PIXELS:
				return "Keyframe %d at %.1f s" % [index, keyframe.time]
	if at_position.y <= PROMPT_LANE.end.y:
		var time := now - PAST_SECONDS + (at_position.x - PADDING) / _pixels_per_second()
		var hovered := {}
		for span in _schedule.spans():
			if span["time"] <= time:
				hovered = span
		if not hovered.is_empty():
			var how := {
				PromptSchedule.State.PLAYED: "Played from",
				PromptSchedule.State.PLAYING: "Playing since",
				PromptSchedule.State.QUEUED: "Queued at",
			}
			return '"%s"\n%s %.1f s' % [hovered["text"], how[hovered["state"]], hovered["time"]]
	return LEGEND


func _on_prompt_started(text: String) -> void:
	_schedule.start(text, _now())


func _now() -> float:
	return generator.get_time() if generator != null else 0.0


func _pixels_per_second() -> float:
	return (size.x - 2.0 * PADDING) / (PAST_SECONDS + FUTURE_SECONDS)


func _x(time: float, now: float) -> float:
	return PADDING + (time - now + PAST_SECONDS) * _pixels_per_second()


# `text` cut with an ellipsis to fit `width` pixels; empty when nothing fits.
func _fit(text: String, width: float) -> String:
	# Prompts may be 2000 characters; no lane shows more than a line of them.
	var fitted := text.left(120)
	while not fitted.is_empty():
		var shown := fitted if fitted.length() == text.length() else fitted + "…"
		if (
			_font.get_string_size(shown, HORIZONTAL_ALIGNMENT_LEFT, -1, UiStyle.FONT_SIZE).x
			<= width
		):
			return shown
		fitted = fitted.left(-1)
	return ""
