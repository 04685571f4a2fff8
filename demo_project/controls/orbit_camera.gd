class_name OrbitCamera
extends Camera3D
## A camera that orbits a point it follows smoothly: drag with the middle or
## right mouse button to orbit, turn the wheel to zoom.
##
## Set [member follow] to a function returning the world point to look at
## (e.g. the character's hips), or Vector3.INF while that is unknown; until it
## returns a point the camera stays where the scene put it. A right click that
## does not drag is left to other handlers (it only counts as a drag once the
## mouse has moved [member drag_threshold] pixels), and left clicks are never
## taken.

## Angle of the camera around the point, from +Z towards +X. The default,
## 135 degrees, looks from behind-left at a character facing +Z.
@export_range(-360.0, 360.0, 0.1, "radians_as_degrees") var yaw := deg_to_rad(135.0)
## Tilt of the view: negative looks down on the point.
@export_range(-89.0, 89.0, 0.1, "radians_as_degrees") var pitch := deg_to_rad(-22.0)
@export_range(0.1, 100.0, 0.01, "suffix:m") var distance := 4.0
@export_range(0.1, 100.0, 0.01, "suffix:m") var min_distance := 1.5
@export_range(0.1, 100.0, 0.01, "suffix:m") var max_distance := 20.0
@export_range(-89.0, 89.0, 0.1, "radians_as_degrees") var min_pitch := deg_to_rad(-80.0)
@export_range(-89.0, 89.0, 0.1, "radians_as_degrees") var max_pitch := deg_to_rad(-4.0)
## Added to the followed point, in world space (e.g. aim above the hips).
@export var focus_offset := Vector3.ZERO
## Seconds for the camera to close 63% of the way to the point (and to a new
## zoom), whatever the frame rate; 0 follows rigidly.
@export_range(0.0, 2.0, 0.01, "suffix:s") var smoothing := 0.25
## Orbit speed, radians per pixel dragged.
@export_range(0.0005, 0.05, 0.0005) var orbit_speed := 0.006
## Distance factor per wheel notch.
@export_range(1.01, 2.0, 0.01) var zoom_step := 1.12
## Pixels a right-button press must move before it is a drag, not a click.
@export_range(0.0, 50.0, 0.5, "suffix:px") var drag_threshold := 5.0

## Returns the world point to follow, or Vector3.INF when it is unknown.
var follow: Callable

var _focus := Vector3.INF
var _shown_distance := 0.0
var _middle_drag := false
var _right_down := false
var _right_drag := false
var _right_travel := Vector2.ZERO


func _process(delta: float) -> void:
	var point: Vector3 = follow.call() if follow.is_valid() else Vector3.INF
	if point == Vector3.INF:
		if _focus == Vector3.INF:
			return  # nothing known yet: keep the scene's placement
	else:
		point += focus_offset
		if _focus == Vector3.INF:
			_focus = point
			_shown_distance = distance
		else:
			_focus = _focus.lerp(point, _approach(delta))
	distance = clampf(distance, min_distance, max_distance)
	pitch = clampf(pitch, min_pitch, max_pitch)
	_shown_distance = lerpf(_shown_distance, distance, _approach(delta))
	_place()


## Jumps to the followed point and the set angles at once (after a teleport).
func snap() -> void:
	var point: Vector3 = follow.call() if follow.is_valid() else Vector3.INF
	if point != Vector3.INF:
		_focus = point + focus_offset
	_shown_distance = distance
	if _focus != Vector3.INF:
		_place()


func _unhandled_input(event: InputEvent) -> void:
	var button := event as InputEventMouseButton
	if button != null:
		_on_button(button)
		return
	var motion := event as InputEventMouseMotion
	if motion == null:
		return
	if _middle_drag and motion.button_mask & MOUSE_BUTTON_MASK_MIDDLE:
		_orbit(motion.relative)
		get_viewport().set_input_as_handled()
	elif _right_down and motion.button_mask & MOUSE_BUTTON_MASK_RIGHT:
		if not _right_drag:
			_right_travel += motion.relative
			_right_drag = _right_travel.length() > drag_threshold
		if _right_drag:
			_orbit(motion.relative)
			get_viewport().set_input_as_handled()


func _on_button(button: InputEventMouseButton) -> void:
	match button.button_index:
		MOUSE_BUTTON_WHEEL_UP, MOUSE_BUTTON_WHEEL_DOWN:
			if button.pressed:
				var step := (
					zoom_step if button.button_index == MOUSE_BUTTON_WHEEL_DOWN else 1.0 / zoom_step
				)
				# Smooth-scrolling devices report fractions of a notch.
				var notches := button.factor if button.factor > 0.0 else 1.0
				distance = clampf(distance * pow(step, notches), min_distance, max_distance)
				get_viewport().set_input_as_handled()
		MOUSE_BUTTON_MIDDLE:
			_middle_drag = button.pressed
			get_viewport().set_input_as_handled()
		MOUSE_BUTTON_RIGHT:
			# The press is left to others: it may be a click. Its release is
			# taken only when it ended a drag.
			if button.pressed:
				_right_down = true
				_right_drag = false
				_right_travel = Vector2.ZERO
			else:
				if _right_drag:
					get_viewport().set_input_as_handled()
				_right_down = false
				_right_drag = false


func _orbit(relative: Vector2) -> void:
	yaw = wrapf(yaw - relative.x * orbit_speed, -PI, PI)
	pitch = clampf(pitch - relative.y * orbit_speed, min_pitch, max_pitch)


# The fraction of the way to close this frame for a time constant of
# `smoothing` seconds: exponential, so any frame rate gives the same motion.
func _approach(delta: float) -> float:
	return 1.0 if smoothing <= 0.0 else 1.0 - exp(-delta / smoothing)


func _place() -> void:
	var orientation := Basis(Vector3.UP, yaw) * Basis(Vector3.RIGHT, pitch)
	global_transform = Transform3D(orientation, _focus + orientation.z * _shown_distance)
