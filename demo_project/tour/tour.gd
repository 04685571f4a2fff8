extends Node
## A scripted tour of the demo, played with the inputs a player uses: keyboard
## steering, a typed prompt, prompts queued on the timeline, clicked
## waypoints, a keyframe preset, then the crowd. scripts/demo.sh --tour
## records it with Movie Maker. With `--screenshots DIR` among the user
## arguments (after `--`) it saves a picture of each feature into DIR.

const MAIN_SCENE := "res://main.tscn"
const CROWD_SCENE := "res://crowd/crowd.tscn"
const LOAD_TIMEOUT_MSEC := 120000

var shots_dir := ""
var main: Node3D
var generator: MotionGenerator


func _ready() -> void:
	var arguments := OS.get_cmdline_user_args()
	var at := arguments.find("--screenshots")
	if at >= 0 and at + 1 < arguments.size():
		shots_dir = arguments[at + 1]
		DirAccess.make_dir_recursive_absolute(shots_dir)
	_run.call_deferred()


func _run() -> void:
	main = (load(MAIN_SCENE) as PackedScene).instantiate()
	add_child(main)
	if not await _wait_generating():
		printerr("tour: the demo did not start generating")
		get_tree().quit(1)
		return
	generator = main.generator
	await _steer()
	await _prompts()
	await _waypoints()
	await _keyframe()
	await _crowd()
	print("tour: done")
	get_tree().quit(0)


func _steer() -> void:
	await _motion(1.5)
	SyntheticInput.key(KEY_W, true)
	await _motion(3.0)
	await _shot("walk")
	SyntheticInput.key(KEY_D, true)
	await _motion(1.5)
	SyntheticInput.key(KEY_W, false)
	SyntheticInput.key(KEY_D, false)
	await _motion(2.0)


func _prompts() -> void:
	SyntheticInput.click(get_viewport(), main.prompt_bar.box().get_global_rect().get_center())
	await get_tree().process_frame
	await SyntheticInput.type_line(get_tree(), "wave with the right hand")
	await _motion(2.5)
	main.timeline.queue_prompt("walk forward", 0.5)
	main.timeline.queue_prompt("wave with the left hand", 4.5)
	await _motion(2.5)
	await _shot("prompts_timeline_hud")
	await _motion(3.5)


func _waypoints() -> void:
	var camera: Camera3D = main.camera
	# Zoom out with the wheel to see the path.
	SyntheticInput.wheel(get_viewport(), get_viewport().get_visible_rect().get_center(), 4)
	await _motion(0.6)
	var hips: Vector3 = main.character.hips
	var forward := -camera.global_basis.z
	forward = Vector3(forward.x, 0, forward.z).normalized()
	var right := Vector3(-forward.z, 0, forward.x)
	var ground := Vector3(hips.x, 0, hips.z)
	for offset in [
		forward * 2.5 + right * 1.0, forward * 4.5 - right * 0.5, forward * 6.0 + right * 1.5
	]:
		SyntheticInput.click(get_viewport(), camera.unproject_position(ground + offset))
		await get_tree().process_frame
	await _motion(2.0)
	await _shot("waypoints")
	await _motion(5.0)


func _keyframe() -> void:
	SyntheticInput.wheel(get_viewport(), get_viewport().get_visible_rect().get_center(), -4)
	main.keyframe_presets.add("Hands up at +2 s")
	await _motion(0.8)
	await _shot("keyframe_ghost")
	await _motion(1.1)
	await _shot("keyframe_reached")
	await _motion(1.5)


func _crowd() -> void:
	main.queue_free()
	main = null
	var crowd: Node3D = (load(CROWD_SCENE) as PackedScene).instantiate()
	add_child(crowd)
	var deadline := Time.get_ticks_msec() + LOAD_TIMEOUT_MSEC
	while crowd.wanderers.is_empty() or not crowd.wanderers[0].generator.is_generating():
		if Time.get_ticks_msec() > deadline:
			return
		await get_tree().process_frame
	generator = crowd.wanderers[0].generator
	await _motion(6.0)
	await _shot("crowd")
	await _motion(2.0)


func _wait_generating() -> bool:
	var deadline := Time.get_ticks_msec() + LOAD_TIMEOUT_MSEC
	while main.generator == null or not main.generator.is_generating():
		if Time.get_ticks_msec() > deadline:
			return false
		await get_tree().process_frame
	return true


## Waits for `seconds` more of motion.
func _motion(seconds: float) -> void:
	var until := generator.get_time() + seconds
	while generator.get_time() < until:
		await get_tree().process_frame


func _shot(shot_name: String) -> void:
	if shots_dir.is_empty():
		return
	await RenderingServer.frame_post_draw
	var path := shots_dir.path_join(shot_name + ".png")
	get_viewport().get_texture().get_image().save_png(path)
	print("tour: saved ", path)
