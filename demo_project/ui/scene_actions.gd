class_name SceneActions
extends PanelContainer
## Buttons for what is not typed: the keyframe presets (each adds a pose a few
## seconds ahead, shown as a ghost) and the way to the crowd scene. Placed at
## the bottom right above the timeline.

var keyframe_presets: KeyframePresets
var crowd_scene := ""


func _init() -> void:
	anchor_left = 1.0
	anchor_right = 1.0
	anchor_top = 1.0
	anchor_bottom = 1.0
	offset_right = -UiStyle.MARGIN
	offset_left = offset_right
	offset_bottom = -PromptTimeline.HEIGHT - 2 * UiStyle.MARGIN
	offset_top = offset_bottom
	grow_horizontal = GROW_DIRECTION_BEGIN
	grow_vertical = GROW_DIRECTION_BEGIN


func _ready() -> void:
	add_theme_stylebox_override("panel", UiStyle.panel(8))
	var column := VBoxContainer.new()
	column.add_theme_constant_override("separation", 4)
	add_child(column)
	column.add_child(UiStyle.label("Keyframes", UiStyle.DIM_TEXT, UiStyle.SMALL_FONT_SIZE))
	for preset: String in KeyframePresets.PRESETS:
		column.add_child(_button(preset, keyframe_presets.add.bind(preset)))
	column.add_child(HSeparator.new())
	column.add_child(_button("Crowd scene", _open_crowd))


func _button(text: String, action: Callable) -> Button:
	var button := Button.new()
	button.text = text
	button.name = text.validate_node_name()
	button.focus_mode = Control.FOCUS_NONE  # the keys keep steering
	button.pressed.connect(action)
	return button


func _open_crowd() -> void:
	get_tree().change_scene_to_file(crowd_scene)
