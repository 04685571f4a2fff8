class_name SyntheticInput
extends RefCounted
## Synthetic player input, sent through Input.parse_input_event as a real
## keyboard and mouse would send it: the tour and the demo's tests use it.


static func key(keycode: Key, pressed: bool) -> void:
	var event := InputEventKey.new()
	event.keycode = keycode
	event.physical_keycode = keycode
	event.pressed = pressed
	Input.parse_input_event(event)


## A press and release of the left (or another) mouse button at `position`
## in the viewport's coordinates (where Controls and
## Camera3D.unproject_position place things), sent where the window has it.
static func click(viewport: Viewport, position: Vector2, button := MOUSE_BUTTON_LEFT) -> void:
	var window_position := viewport.get_final_transform() * position
	for pressed in [true, false]:
		var event := InputEventMouseButton.new()
		event.button_index = button
		event.pressed = pressed
		event.position = window_position
		event.global_position = window_position
		Input.parse_input_event(event)


## `notches` turns of the mouse wheel at `position` (viewport coordinates):
## positive zooms out (wheel down), negative in.
static func wheel(viewport: Viewport, position: Vector2, notches: int) -> void:
	var button := MOUSE_BUTTON_WHEEL_DOWN if notches > 0 else MOUSE_BUTTON_WHEEL_UP
	for notch in absi(notches):
		click(viewport, position, button)


## Types `text` one character per frame into whatever has the focus, then Enter.
static func type_line(tree: SceneTree, text: String) -> void:
	for character in text:
		var event := InputEventKey.new()
		event.pressed = true
		event.unicode = character.unicode_at(0)
		event.keycode = OS.find_keycode_from_string(character) if character != " " else KEY_SPACE
		Input.parse_input_event(event)
		await tree.process_frame
	key(KEY_ENTER, true)
	key(KEY_ENTER, false)
	await tree.process_frame
