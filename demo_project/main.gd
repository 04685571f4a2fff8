extends Node3D
## Demo entry point, for now: a stick figure driven by a MotionGenerator with
## the shipped model, followed by the camera. Type a prompt and press Enter,
## steer with WASD / arrows (Shift runs), click the ground for waypoints
## (right click clears). Headless (no display) it plays a few seconds,
## reports how far the character walked and quits.

const DEFAULT_MODEL := "res://addons/ardy/models/default"
const HEADLESS_SECONDS := 4.0
const CAMERA_OFFSET := Vector3(-1.8, 0.9, 2.2)

var generator: MotionGenerator
var start := Vector3.INF
var hips := Vector3.INF
var shown_prompt := ""

@onready var status_label: Label = $UI/Status
@onready var character: Node3D = $Character
@onready var camera: Camera3D = $Camera3D
@onready var prompt_box: LineEdit = $UI/Prompt


func _ready() -> void:
	if not ClassDB.class_exists("MotionGenerator"):
		_report("ARDY extension NOT loaded: build it with scripts/demo.sh.", false)
		return
	var skeleton := StickFigure.build(DEFAULT_MODEL)
	character.add_child(skeleton)
	# Generated poses exist in the skeleton's update (modifiers are not kept
	# in the bone poses), so read them when it has finished.
	skeleton.skeleton_updated.connect(
		func() -> void: hips = skeleton.global_transform * skeleton.get_bone_global_pose(0).origin
	)
	generator = MotionGenerator.new()
	generator.skeleton = NodePath("../Skeleton3D")
	generator.prompt = "walk forward"
	generator.playing = true
	generator.generation_failed.connect(func(message: String) -> void: _report(message, false))
	generator.prompt_started.connect(func(text: String) -> void: shown_prompt = text)
	character.add_child(generator)
	_add_controls()


func _add_controls() -> void:
	DemoInputActions.ensure()
	var steering := KeyboardSteering.new()
	steering.name = "KeyboardSteering"
	steering.generator = generator
	steering.camera = camera
	add_child(steering)
	var clicks := ClickWaypoints.new()
	clicks.name = "ClickWaypoints"
	clicks.generator = generator
	clicks.camera = camera
	clicks.hips_position = func() -> Vector3: return hips
	add_child(clicks)
	prompt_box.text_submitted.connect(_on_prompt_submitted)


func _on_prompt_submitted(text: String) -> void:
	if not text.strip_edges().is_empty():
		generator.target_velocity = Vector3.ZERO
		generator.prompt = text.strip_edges()
	prompt_box.release_focus()  # the keys steer again


func _process(delta: float) -> void:
	if generator == null or not generator.is_generating() or hips == Vector3.INF:
		status_label.text = "Loading the model..."
		return
	if start == Vector3.INF:
		start = hips
		camera.position = hips + CAMERA_OFFSET
	# The camera follows the hips smoothly.
	var focus := Vector3(hips.x, 1.0, hips.z)
	camera.position = camera.position.lerp(focus + CAMERA_OFFSET, minf(1.0, 2.0 * delta))
	camera.look_at(focus)
	var stats := generator.get_stats()
	status_label.text = (
		"%s  |  t = %.1f s  |  window %.0f ms  |  buffered %.2f s"
		% [shown_prompt, generator.get_time(), stats["last_latency_ms"], stats["buffered_seconds"]]
	)
	if _reports_headless() and generator.get_time() >= HEADLESS_SECONDS:
		var walked := Vector2(hips.x - start.x, hips.z - start.z).length()
		_report(
			"Demo: the character walked %.2f m in %.0f s." % [walked, HEADLESS_SECONDS],
			walked > 1.0
		)


func _report(message: String, ok: bool) -> void:
	status_label.text = message
	if ok:
		print(message)
	else:
		printerr(message)
	if _reports_headless():
		get_tree().quit(0 if ok else 1)


# Run headless as the main scene (not inside a test): report and quit.
func _reports_headless() -> bool:
	return DisplayServer.get_name() == "headless" and get_tree().current_scene == self
