class_name KeyboardSteering
extends Node
## WASD / arrow keys set the character's target velocity relative to the
## camera (Shift runs); releasing the keys stops it.

const WALK_SPEED := 1.2
const RUN_SPEED := 2.5

var generator: MotionGenerator
var camera: Camera3D
var _steering := false


func _process(_delta: float) -> void:
	if generator == null or camera == null or get_viewport().gui_get_focus_owner() is LineEdit:
		return
	var input := Input.get_vector("move_left", "move_right", "move_forward", "move_back")
	if input.is_zero_approx():
		if _steering:
			_steering = false
			generator.target_velocity = Vector3.ZERO
			generator.prompt = "stand still"
		return
	# The camera's ground-plane axes: forward is where it looks.
	var forward := -camera.global_basis.z
	forward = Vector3(forward.x, 0, forward.z).normalized()
	var right := Vector3(-forward.z, 0, forward.x)
	var running := Input.is_action_pressed("run")
	var velocity := (right * input.x - forward * input.y).normalized()
	velocity *= RUN_SPEED if running else WALK_SPEED
	var prompt := "run" if running else "walk"
	if not _steering or generator.prompt != prompt:
		generator.prompt = prompt
	_steering = true
	if not velocity.is_equal_approx(generator.target_velocity):
		generator.target_velocity = velocity
