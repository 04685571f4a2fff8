class_name PromptBar
extends VBoxContainer
## The prompt box with a row of preset prompts above it. Enter (or a preset)
## emits `prompt_chosen`; Up and Down walk through the prompts used before.
## Placed at the bottom left above the PromptQueueRow unless anchors and
## offsets are set after new().

signal prompt_chosen(text: String)

## Prompts the model knows (the actions and styles of its training data),
## left and right variants included.
const PRESETS: Array[String] = [
	"walk forward",
	"run",
	"walk backwards",
	"walk and turn left",
	"walk and turn right",
	"wave with the left hand",
	"wave with the right hand",
	"wave both hands",
	"raise the left hand",
	"raise the right hand",
	"raise both hands",
	"bow",
	"punch",
	"kick",
	"dance",
	"walk like an old man",
	"walk happily",
	"stand still",
]
const HISTORY_SIZE := 20
const WIDTH := 560.0

var history: Array[String] = []
var _history_index := -1
var _box: LineEdit


func _init() -> void:
	anchor_top = 1.0
	anchor_bottom = 1.0
	offset_left = UiStyle.MARGIN
	offset_right = UiStyle.MARGIN + WIDTH
	offset_bottom = -PromptTimeline.HEIGHT - PromptQueueRow.HEIGHT - 3 * UiStyle.MARGIN
	offset_top = offset_bottom
	grow_vertical = GROW_DIRECTION_BEGIN


func _ready() -> void:
	add_theme_constant_override("separation", 6)
	var presets := HFlowContainer.new()
	presets.name = "Presets"
	presets.add_theme_constant_override("h_separation", 4)
	presets.add_theme_constant_override("v_separation", 4)
	for text in PRESETS:
		var button := Button.new()
		button.text = text
		button.name = text
		button.focus_mode = Control.FOCUS_NONE  # the keys keep steering
		button.add_theme_font_size_override("font_size", UiStyle.SMALL_FONT_SIZE)
		button.pressed.connect(choose.bind(text))
		presets.add_child(button)
	add_child(presets)
	_box = LineEdit.new()
	_box.name = "Prompt"
	_box.placeholder_text = 'Type a prompt ("wave with the left hand") and press Enter'
	_box.text_submitted.connect(_on_submitted)
	_box.gui_input.connect(_on_box_input)
	add_child(_box)


## The prompt box itself.
func box() -> LineEdit:
	return _box


## Uses `text` as the prompt and remembers it.
func choose(text: String) -> void:
	var prompt := text.strip_edges()
	if prompt.is_empty():
		return
	history.erase(prompt)
	history.push_front(prompt)
	if history.size() > HISTORY_SIZE:
		history.pop_back()
	_history_index = -1
	prompt_chosen.emit(prompt)


func _on_submitted(text: String) -> void:
	choose(text)
	_box.clear()
	_box.release_focus()  # the keys steer again


func _on_box_input(event: InputEvent) -> void:
	var key := event as InputEventKey
	if key == null or not key.pressed or history.is_empty():
		return
	if key.keycode == KEY_UP:
		_history_index = mini(_history_index + 1, history.size() - 1)
	elif key.keycode == KEY_DOWN:
		_history_index = maxi(_history_index - 1, -1)
	else:
		return
	_box.text = history[_history_index] if _history_index >= 0 else ""
	_box.caret_column = _box.text.length()
	_box.accept_event()
