class_name StatsHud
extends PanelContainer
## A compact panel of a MotionGenerator's streaming figures: window latency,
## what is buffered, history, windows and splices, late windows and underrun,
## the prompt playing, the frame rate, the node's main-thread cost and the
## motion clock. Refreshed four times a second: numbers redrawn every frame
## cannot be read. Placed at the top left unless anchors and offsets are set
## after new().

const REFRESH_SECONDS := 0.25
## Characters per line; the panel keeps this width whatever it shows.
const COLUMNS := 39
const ERROR_SECONDS := 8.0
const LEGEND := (
	"window: latency of the last generated window; median over recent ones\n"
	+ "buffer: replan buffer of the last window; ahead: motion generated ahead\n"
	+ "history: past motion each window continues from\n"
	+ "main thr: median main-thread cost of the node per frame\n"
	+ "splices: windows cut in for a new command; late: windows that came late\n"
	+ "underrun: playhead time lost waiting for frames"
)

var generator: MotionGenerator
var _text: RichTextLabel
var _prompt := ""
var _error := ""
var _error_until := 0.0


func _init() -> void:
	anchor_left = 0.0
	anchor_right = 0.0
	anchor_top = 0.0
	anchor_bottom = 0.0
	offset_left = UiStyle.MARGIN
	offset_top = UiStyle.MARGIN
	offset_right = UiStyle.MARGIN
	offset_bottom = UiStyle.MARGIN


func _ready() -> void:
	add_theme_stylebox_override("panel", UiStyle.panel(10))
	tooltip_text = LEGEND
	var font := UiStyle.mono_font()
	_text = RichTextLabel.new()
	_text.bbcode_enabled = true
	_text.fit_content = true
	_text.scroll_active = false
	_text.autowrap_mode = TextServer.AUTOWRAP_OFF
	_text.mouse_filter = MOUSE_FILTER_IGNORE
	_text.add_theme_font_override("normal_font", font)
	_text.add_theme_font_size_override("normal_font_size", UiStyle.FONT_SIZE - 1)
	_text.add_theme_color_override("default_color", UiStyle.TEXT)
	var char_width := (
		font.get_string_size("0", HORIZONTAL_ALIGNMENT_LEFT, -1, UiStyle.FONT_SIZE - 1).x
	)
	_text.custom_minimum_size.x = ceilf(char_width * COLUMNS)
	add_child(_text)
	if generator != null:
		generator.prompt_started.connect(func(text: String) -> void: _prompt = text)
		generator.generation_failed.connect(_on_failed)
	var timer := Timer.new()
	timer.wait_time = REFRESH_SECONDS
	timer.autostart = true
	timer.timeout.connect(_refresh)
	add_child(timer)
	_refresh()


func _refresh() -> void:
	var lines: PackedStringArray = []
	var fps := Engine.get_frames_per_second()
	if generator == null:
		lines.append(_line("status", _dim("no generator")))
	elif not generator.is_generating():
		var waiting := "loading the model" if not generator.is_model_loaded() else "not playing"
		lines.append(_line("status", _dim(waiting + "…")))
		lines.append(_line("fps", "%4d" % fps))
	else:
		lines.append_array(_figures(generator.get_stats(), fps))
	if not _error.is_empty() and Time.get_ticks_msec() / 1000.0 < _error_until:
		lines.append(_line("error", _warn(_cut(_error, COLUMNS - 10))))
	_text.text = "\n".join(lines)


func _figures(stats: Dictionary, fps: float) -> PackedStringArray:
	var late: int = stats.get("late_windows", 0)
	var failed: int = stats.get("failed_windows", 0)
	var underrun: float = stats.get("underrun_seconds", 0.0)
	var prompt := _prompt if not _prompt.is_empty() else generator.prompt
	var shown := _cut(prompt, COLUMNS - 9) if not prompt.is_empty() else _dim("none")
	return PackedStringArray(
		[
			_line("prompt", shown),
			_pair("clock", "%6.2f s " % generator.get_time(), "fps", "%6d   " % fps),
			_pair(
				"window",
				"%6.1f ms" % stats.get("last_latency_ms", 0.0),
				"median",
				"%6.1f ms" % stats.get("median_latency_ms", 0.0)
			),
			_pair(
				"buffer",
				"%6d fr" % int(stats.get("buffer_frames", 0)),
				"ahead",
				"%6.2f s " % stats.get("buffered_seconds", 0.0)
			),
			_pair(
				"history",
				"%6.1f s " % stats.get("history_seconds", 0.0),
				"main thr",
				"%6d µs" % int(stats.get("main_thread_usec", 0))
			),
			_pair(
				"windows",
				"%6d   " % int(stats.get("windows", 0)),
				"splices",
				"%6d   " % int(stats.get("splices", 0))
			),
			_pair(
				"late",
				_flag("%6d   " % late, late > 0),
				"underrun",
				_flag("%6.2f s " % underrun, underrun > 0.0)
			),
			_line("failed", _flag("%6d" % failed, failed > 0)),
		]
	)


func _on_failed(message: String) -> void:
	_error = message
	_error_until = Time.get_ticks_msec() / 1000.0 + ERROR_SECONDS
	tooltip_text = message + "\n\n" + LEGEND
	_refresh()


# One line: a dimmed name in a fixed column, then its value.
func _line(title: String, value: String) -> String:
	return _dim(title.rpad(9)) + value


# Two name and value columns on one line; values are 9 characters wide.
func _pair(title: String, value: String, second_title: String, second_value: String) -> String:
	return _line(title, value) + "   " + _dim(second_title.rpad(9)) + second_value


func _dim(text: String) -> String:
	return "[color=#%s]%s[/color]" % [UiStyle.DIM_TEXT.to_html(false), text]


func _warn(text: String) -> String:
	return "[color=#%s]%s[/color]" % [UiStyle.WARNING.to_html(false), text]


func _flag(text: String, warn: bool) -> String:
	return _warn(text) if warn else text


# `text` at most `count` characters, escaped for BBCode.
func _cut(text: String, count: int) -> String:
	var cut := text if text.length() <= count else text.left(count - 1) + "…"
	return cut.replace("[", "[lb]")
