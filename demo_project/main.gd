extends Node3D
## The demo: a mannequin driven by a MotionGenerator with the shipped model,
## through the node's retargeting (the mannequin's rig is not the model's).
## Type a prompt or pick a preset, queue prompts on the timeline, steer with
## WASD / arrows (Shift runs), click the ground for waypoints (right click
## clears), add keyframe presets, tune the settings, or open the crowd.
## Headless (no display) as the main scene it plays a few seconds, reports
## how far the character walked and quits.

const HEADLESS_SECONDS := 4.0
const CROWD_SCENE := "res://crowd/crowd.tscn"

var generator: MotionGenerator
var prompt_bar: PromptBar
var timeline: PromptTimeline
var keyframe_presets: KeyframePresets
var click_waypoints: ClickWaypoints
var _start := Vector3.INF

@onready var character: DemoCharacter = $Character
@onready var camera: OrbitCamera = $Camera
@onready var controls: Node3D = $Controls
@onready var ui: CanvasLayer = $UI


func _ready() -> void:
	generator = character.generator
	generator.prompt = "walk forward"
	camera.follow = func() -> Vector3: return character.hips
	_add_controls()
	_add_ui()


func _add_controls() -> void:
	DemoInputActions.ensure()
	var steering := KeyboardSteering.new()
	steering.name = "KeyboardSteering"
	steering.generator = generator
	steering.camera = camera
	controls.add_child(steering)
	click_waypoints = ClickWaypoints.new()
	click_waypoints.name = "ClickWaypoints"
	click_waypoints.generator = generator
	click_waypoints.camera = camera
	click_waypoints.hips_position = func() -> Vector3: return character.hips
	controls.add_child(click_waypoints)
	keyframe_presets = KeyframePresets.new()
	keyframe_presets.name = "KeyframePresets"
	keyframe_presets.generator = generator
	controls.add_child(keyframe_presets)


func _add_ui() -> void:
	var hud := StatsHud.new()
	hud.name = "StatsHud"
	hud.generator = generator
	ui.add_child(hud)
	var settings := SettingsPanel.new()
	settings.name = "Settings"
	settings.generator = generator
	# A restart drops the goals with the motion: their marks go too.
	settings.restarted.connect(click_waypoints.clear)
	settings.restarted.connect(keyframe_presets.clear)
	ui.add_child(settings)
	timeline = PromptTimeline.new()
	timeline.name = "Timeline"
	timeline.generator = generator
	ui.add_child(timeline)
	var queue_row := PromptQueueRow.new()
	queue_row.name = "PromptQueue"
	queue_row.timeline = timeline
	ui.add_child(queue_row)
	prompt_bar = PromptBar.new()
	prompt_bar.name = "PromptBar"
	prompt_bar.prompt_chosen.connect(_on_prompt_chosen)
	ui.add_child(prompt_bar)
	var actions := SceneActions.new()
	actions.name = "Actions"
	actions.keyframe_presets = keyframe_presets
	actions.crowd_scene = CROWD_SCENE
	ui.add_child(actions)


func _on_prompt_chosen(text: String) -> void:
	generator.target_velocity = Vector3.ZERO
	generator.prompt = text


func _process(_delta: float) -> void:
	var hips := character.hips
	if hips == Vector3.INF or not _reports_headless():
		return
	if _start == Vector3.INF:
		_start = hips
	if generator.get_time() >= HEADLESS_SECONDS:
		var walked := Vector2(hips.x - _start.x, hips.z - _start.z).length()
		_report(
			"Demo: the character walked %.2f m in %.0f s." % [walked, HEADLESS_SECONDS],
			walked > 1.0
		)


func _report(message: String, ok: bool) -> void:
	if ok:
		print(message)
	else:
		printerr(message)
	if _reports_headless():
		get_tree().quit(0 if ok else 1)


# Run headless as the main scene (not inside a test or the tour): report and quit.
func _reports_headless() -> bool:
	return DisplayServer.get_name() == "headless" and get_tree().current_scene == self
