class_name SettingsPanel
extends VBoxContainer
## A "Settings" button that opens a panel of the generator's sampling and
## streaming settings, each control bound live to its property. The settings
## the node reads only when generation starts are starred, and Restart starts
## the motion again with them. While open it follows the generator: a value
## that other code sets shows within a frame. Placed at the top right unless
## anchors and offsets are set after new().

## After Restart: the node dropped its goals and queued prompts with the motion.
signal restarted

const WIDTH := 440.0
const MAX_STEPS := 50
const MAX_GUIDANCE := 10.0
# Where a control rests while the model's own value is used, until the model
# has loaded (then its own values, get_model_sampling()): the shipped model's
# defaults, so moving it starts from a familiar value.
const MODEL_STEPS := 4
const MODEL_GUIDANCE := 2.0
const MODEL_PATH_GUIDANCE := 0.5
const MIN_PATH_GUIDANCE := 0.05
const MODEL_TEXT_ONLY_GUIDANCE := 1.0
const MIN_TEXT_ONLY_GUIDANCE := 0.25
const MAX_TEXT_ONLY_GUIDANCE := 4.0
const MAX_REPLAN_FRAMES := 40
const MODEL_FPS := 20.0
const MAX_SEED := 2147483647
# The generator's properties the panel shows.
const SHOWN := [
	&"steps",
	&"text_guidance",
	&"constraint_guidance",
	&"path_guidance_scale",
	&"text_only_guidance_scale",
	&"history_seconds",
	&"replan_buffer_frames",
	&"seed",
	&"foot_lock",
]

var generator: MotionGenerator
## Whether the panel starts open.
var expanded := false

var _body: PanelContainer
var _grid: GridContainer
var _steps: SpinBox
var _steps_value: Label
var _steps_default: CheckBox
# The guidance weights' rows: property -> {slider, value, use_default, model_value, format}.
var _weights := {}
var _history: HSlider
var _history_value: Label
var _replan: SpinBox
var _replan_value: Label
var _seed: SpinBox
var _foot_lock: CheckBox
# The values shown, as last read from the generator.
var _shown_values := []


func _init() -> void:
	anchor_left = 1.0
	anchor_right = 1.0
	anchor_top = 0.0
	anchor_bottom = 0.0
	offset_left = -WIDTH - UiStyle.MARGIN
	offset_right = -UiStyle.MARGIN
	offset_top = UiStyle.MARGIN
	offset_bottom = UiStyle.MARGIN
	grow_horizontal = GROW_DIRECTION_BEGIN
	# Only the button and the open panel take clicks; the rest of the column
	# lets them through to the scene.
	mouse_filter = MOUSE_FILTER_IGNORE


func _ready() -> void:
	var toggle := Button.new()
	toggle.text = "Settings"
	toggle.toggle_mode = true
	toggle.focus_mode = FOCUS_NONE
	toggle.size_flags_horizontal = SIZE_SHRINK_END
	toggle.toggled.connect(_set_expanded)
	add_child(toggle)
	_body = PanelContainer.new()
	_body.add_theme_stylebox_override("panel", UiStyle.panel(12))
	add_child(_body)
	var column := VBoxContainer.new()
	column.add_theme_constant_override("separation", 10)
	_body.add_child(column)
	_grid = GridContainer.new()
	_grid.columns = 4
	_grid.add_theme_constant_override("h_separation", 10)
	_grid.add_theme_constant_override("v_separation", 6)
	column.add_child(_grid)
	_add_sampling_rows()
	_add_restart_rows()
	column.add_child(_footer())
	toggle.button_pressed = expanded
	_set_expanded(expanded)


# The node has no signal for its settings: compare what it holds each frame
# (nine property reads and the model's own sampling) and redraw only on a change.
func _process(_delta: float) -> void:
	if generator != null and _values() != _shown_values:
		_refresh()


# Read live by the node: they change the next window.
func _add_sampling_rows() -> void:
	_steps = _spin_box(1, MAX_STEPS, 1)
	_steps.value_changed.connect(func(value: float) -> void: _apply("steps", int(value)))
	_steps_value = _value_label()
	_steps_default = _default_box()
	_steps_default.toggled.connect(
		func(on: bool) -> void: _apply("steps", 0 if on else int(_steps.value))
	)
	_row(
		"Diffusion steps",
		_steps,
		_steps_value,
		_steps_default,
		"Denoising steps per window (steps); more cost proportionally more time"
	)
	_add_weight_row(
		"Text guidance",
		"text_guidance",
		0.0,
		MAX_GUIDANCE,
		0.1,
		MODEL_GUIDANCE,
		"How strongly the prompt steers the motion (text_guidance)"
	)
	_add_weight_row(
		"Goal guidance",
		"constraint_guidance",
		0.0,
		MAX_GUIDANCE,
		0.1,
		MODEL_GUIDANCE,
		"How strongly waypoints, keyframes and targets steer it (constraint_guidance)"
	)
	_add_weight_row(
		"Path guidance",
		"path_guidance_scale",
		MIN_PATH_GUIDANCE,
		1.0,
		0.05,
		MODEL_PATH_GUIDANCE,
		(
			"Goal guidance times this while the only goal is a path (keys, clicked waypoints):"
			+ "\nlower lets the feet slide less under it (path_guidance_scale)"
		)
	)
	_add_weight_row(
		"Text alone",
		"text_only_guidance_scale",
		MIN_TEXT_ONLY_GUIDANCE,
		MAX_TEXT_ONLY_GUIDANCE,
		0.05,
		MODEL_TEXT_ONLY_GUIDANCE,
		(
			"Text guidance times this while there is no goal to follow:"
			+ "\nhigher makes the prompt plainer and quicker to show (text_only_guidance_scale)"
		)
	)


# A slider, its value and a "default" box for a weight the node reads as the model's own
# when negative; meanwhile the slider rests at the model's own value (`model_value` until
# the model has loaded).
func _add_weight_row(
	title: String,
	property: StringName,
	low: float,
	high: float,
	step: float,
	model_value: float,
	tip: String
) -> void:
	var slider := _slider(low, high, step)
	slider.value_changed.connect(func(weight: float) -> void: _apply(property, weight))
	var use_default := _default_box()
	use_default.toggled.connect(
		func(on: bool) -> void: _apply(property, -1.0 if on else slider.value)
	)
	var value := _value_label()
	_row(title, slider, value, use_default, tip)
	# As many decimals as the slider's step shows.
	var decimals := 1 if step >= 0.1 else 2
	_weights[property] = {
		"slider": slider,
		"value": value,
		"use_default": use_default,
		"model_value": model_value,
		"format": "%%.%df" % decimals,
	}


# Read by the node when generation (re)starts.
func _add_restart_rows() -> void:
	_history = _slider(0.0, 8.0, 0.5)
	_history_value = _value_label()
	_history.value_changed.connect(func(value: float) -> void: _apply("history_seconds", value))
	_row(
		"History *",
		_history,
		_history_value,
		Control.new(),
		"Seconds of past motion each window continues from (history_seconds)"
	)
	_replan = _spin_box(0, MAX_REPLAN_FRAMES, 1)
	_replan.suffix = "fr"
	_replan_value = _value_label()
	_replan.value_changed.connect(
		func(value: float) -> void: _apply("replan_buffer_frames", int(value))
	)
	_row(
		"Replan buffer *",
		_replan,
		_replan_value,
		Control.new(),
		"Frames that keep playing while the next window is made (replan_buffer_frames)"
	)
	_seed = _spin_box(0, MAX_SEED, 1)
	_seed.value_changed.connect(func(value: float) -> void: _apply("seed", int(value)))
	var new_seed := Button.new()
	new_seed.text = "New seed"
	new_seed.focus_mode = FOCUS_NONE
	new_seed.pressed.connect(func() -> void: _apply("seed", randi() % MAX_SEED))
	_row(
		"Seed *",
		_seed,
		Control.new(),
		new_seed,
		"Seed of the windows' noise: same seed, prompt and goals, same motion (seed)"
	)
	_foot_lock = CheckBox.new()
	_foot_lock.text = "on"
	_foot_lock.focus_mode = FOCUS_NONE
	UiStyle.style_check_box(_foot_lock)
	_foot_lock.toggled.connect(func(on: bool) -> void: _apply("foot_lock", on))
	_row(
		"Foot lock *",
		_foot_lock,
		Control.new(),
		Control.new(),
		"Holds planted feet in place, removing foot sliding (foot_lock)"
	)


func _footer() -> HBoxContainer:
	var footer := HBoxContainer.new()
	var note := UiStyle.label("* applies on restart", UiStyle.DIM_TEXT, UiStyle.SMALL_FONT_SIZE)
	note.size_flags_horizontal = SIZE_EXPAND_FILL
	footer.add_child(note)
	var restart := Button.new()
	restart.text = "Restart motion"
	restart.focus_mode = FOCUS_NONE
	restart.tooltip_text = "Starts the motion again from the rest pose with these settings\n"
	restart.tooltip_text += "(waypoints, keyframes and queued prompts are dropped)"
	restart.pressed.connect(_restart)
	footer.add_child(restart)
	return footer


func _set_expanded(on: bool) -> void:
	expanded = on
	_body.visible = on
	set_process(on)
	if on:
		_refresh()  # other code may have changed the generator meanwhile


func _apply(property: StringName, value: Variant) -> void:
	if generator != null:
		generator.set(property, value)
	# The node refuses values out of its range and keeps the previous one:
	# show what it holds.
	_refresh()


func _restart() -> void:
	if generator == null or not generator.is_generating():
		return  # generation has not started: it will start with these settings
	generator.reset()
	restarted.emit()


# Every control shows what the generator holds, without writing back.
func _refresh() -> void:
	if generator == null or _grid == null:
		return
	_shown_values = _values()
	var steps := generator.steps
	_steps_default.set_pressed_no_signal(steps <= 0)
	var model_sampling := generator.get_model_sampling()
	_steps.set_value_no_signal(steps if steps > 0 else model_sampling.get("steps", MODEL_STEPS))
	_steps_value.text = "" if steps > 0 else "auto"
	_steps_value.add_theme_color_override("font_color", UiStyle.DIM_TEXT)
	for property: StringName in _weights:
		var row: Dictionary = _weights[property]
		var model_value: float = model_sampling.get(property, row["model_value"])
		_show_weight(generator.get(property), row, model_value)
	_history.set_value_no_signal(generator.history_seconds)
	_history_value.text = "%.1f s" % generator.history_seconds
	_replan.set_value_no_signal(generator.replan_buffer_frames)
	_replan_value.text = "%.2f s" % (generator.replan_buffer_frames / MODEL_FPS)
	_seed.set_value_no_signal(generator.seed)
	_foot_lock.set_pressed_no_signal(generator.foot_lock)


func _values() -> Array:
	var values := SHOWN.map(func(property: StringName) -> Variant: return generator.get(property))
	values.append(generator.get_model_sampling())
	return values


# `model_value`: where the slider rests while the model's own value is used.
func _show_weight(weight: float, row: Dictionary, model_value: float) -> void:
	var use_default: CheckBox = row["use_default"]
	var slider: HSlider = row["slider"]
	var value: Label = row["value"]
	use_default.set_pressed_no_signal(weight < 0.0)
	slider.set_value_no_signal(weight if weight >= 0.0 else model_value)
	value.text = row["format"] % weight if weight >= 0.0 else "auto"
	value.add_theme_color_override(
		"font_color", UiStyle.TEXT if weight >= 0.0 else UiStyle.DIM_TEXT
	)


func _row(title: String, control: Control, value: Control, extra: Control, tip: String) -> void:
	var label := UiStyle.label(title)
	# Labels ignore the mouse by default, which would hide their tooltips.
	label.mouse_filter = MOUSE_FILTER_PASS
	label.tooltip_text = tip
	control.tooltip_text = tip
	control.size_flags_horizontal = SIZE_EXPAND_FILL
	control.size_flags_vertical = SIZE_SHRINK_CENTER
	for cell: Control in [label, control, value, extra]:
		_grid.add_child(cell)


func _spin_box(low: float, high: float, step: float) -> SpinBox:
	var box := SpinBox.new()
	box.min_value = low
	box.max_value = high
	box.step = step
	box.custom_minimum_size.x = 120
	# Enter applies the typed value and hands the keys back to steering.
	box.get_line_edit().text_submitted.connect(
		func(_text: String) -> void: get_viewport().gui_release_focus()
	)
	return box


func _slider(low: float, high: float, step: float) -> HSlider:
	var slider := HSlider.new()
	slider.min_value = low
	slider.max_value = high
	slider.step = step
	slider.custom_minimum_size.x = 140
	# A focused slider would take the arrow keys, which steer the character.
	slider.focus_mode = FOCUS_NONE
	UiStyle.style_slider(slider)
	return slider


func _value_label() -> Label:
	var label := UiStyle.label("")
	label.add_theme_font_override("font", UiStyle.mono_font())
	label.custom_minimum_size.x = 52
	label.horizontal_alignment = HORIZONTAL_ALIGNMENT_RIGHT
	return label


func _default_box() -> CheckBox:
	var box := CheckBox.new()
	box.text = "default"
	box.focus_mode = FOCUS_NONE
	box.tooltip_text = "Use the model's own value"
	UiStyle.style_check_box(box)
	return box
