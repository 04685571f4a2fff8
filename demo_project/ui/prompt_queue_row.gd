class_name PromptQueueRow
extends PanelContainer
## A row for queueing a prompt on a PromptTimeline: the text, "in N s", and a
## Queue button (Enter in the text box queues too). Placed at the bottom left,
## just above the timeline, unless anchors and offsets are set after new().

const WIDTH := 560.0
const HEIGHT := 44.0
const DEFAULT_DELAY := 3.0
const MAX_DELAY := 60.0

var timeline: PromptTimeline
var _text: LineEdit
var _delay: SpinBox


func _init() -> void:
	anchor_left = 0.0
	anchor_right = 0.0
	anchor_top = 1.0
	anchor_bottom = 1.0
	offset_left = UiStyle.MARGIN
	offset_right = UiStyle.MARGIN + WIDTH
	offset_bottom = -PromptTimeline.HEIGHT - 2 * UiStyle.MARGIN
	offset_top = offset_bottom - HEIGHT
	grow_vertical = GROW_DIRECTION_BEGIN


func _ready() -> void:
	add_theme_stylebox_override("panel", UiStyle.panel(6))
	var row := HBoxContainer.new()
	row.add_theme_constant_override("separation", 8)
	add_child(row)
	_text = LineEdit.new()
	_text.placeholder_text = "Queue a prompt: wave with the left hand"
	_text.size_flags_horizontal = SIZE_EXPAND_FILL
	_text.text_submitted.connect(func(_submitted: String) -> void: _queue())
	row.add_child(_text)
	row.add_child(UiStyle.label("in"))
	_delay = SpinBox.new()
	_delay.min_value = 0.0
	_delay.max_value = MAX_DELAY
	_delay.step = 0.5
	_delay.value = DEFAULT_DELAY
	_delay.suffix = "s"
	_delay.tooltip_text = "Seconds from now on the motion clock"
	_delay.get_line_edit().text_submitted.connect(
		func(_submitted: String) -> void: get_viewport().gui_release_focus()
	)
	row.add_child(_delay)
	var button := Button.new()
	button.text = "Queue"
	# Without focus, the keyboard keeps steering after a click.
	button.focus_mode = FOCUS_NONE
	button.pressed.connect(_queue)
	row.add_child(button)


func _queue() -> void:
	if timeline != null and not _text.text.strip_edges().is_empty():
		timeline.queue_prompt(_text.text, _delay.value)
		_text.clear()
	# Focus back to the game, so the keys steer again.
	get_viewport().gui_release_focus()
