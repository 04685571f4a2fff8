class_name KeyframePresets
extends Node3D
## Pose keyframes a few seconds ahead ("hands up at +2 s"): each is shown as a
## translucent ghost of the character where the plan puts it then, until
## reached.

## Preset -> [pose in PoseLibrary, seconds ahead].
const PRESETS := {
	"Hands up at +2 s": ["hands up", 2.0],
	"Crouch at +3 s": ["crouch", 3.0],
	"T-pose at +2 s": ["t-pose", 2.0],
}
const GHOST_COLOR := Color(0.93, 0.42, 0.78, 0.35)
const FADE_SECONDS := 0.6

var generator: MotionGenerator
## Ghosts by keyframe index in the generator's list.
var _ghosts: Dictionary = {}


func _ready() -> void:
	generator.keyframe_reached.connect(_on_reached)


## Adds the keyframe of a preset (a key of PRESETS) and shows its ghost.
func add(preset: String) -> void:
	var pose_name: String = PRESETS[preset][0]
	var seconds_ahead: float = PRESETS[preset][1]
	var ghost := Mannequin.build_ghost(GHOST_COLOR)
	ghost.name = "Ghost"
	PoseLibrary.apply(ghost, pose_name)
	generator.add_pose_keyframe(ghost, generator.get_time() + seconds_ahead)
	add_child(ghost)
	_ghosts[generator.get_keyframes().size() - 1] = ghost
	_process(0.0)


## Removes every ghost (the keyframes themselves are the generator's).
func clear() -> void:
	for ghost: Node in _ghosts.values():
		ghost.queue_free()
	_ghosts.clear()


# Each ghost stands where the motion generated so far puts the character at
# its time; the place settles once a window has planned the pose.
func _process(_delta: float) -> void:
	var keyframes := generator.get_keyframes()
	for index: int in _ghosts:
		if index < keyframes.size():
			var planned: Variant = generator.get_planned_root(keyframes[index].time)
			if planned is Transform3D:
				(_ghosts[index] as Node3D).global_transform = planned


func _on_reached(index: int) -> void:
	var ghost: Skeleton3D = _ghosts.get(index)
	if ghost == null:
		return
	_ghosts.erase(index)
	var fade := ghost.create_tween()
	for mesh: MeshInstance3D in ghost.find_children("*", "MeshInstance3D", false, false):
		# The ghost's colour pass follows its depth pass (Mannequin.build_ghost).
		var shaded := mesh.material_override.next_pass as ShaderMaterial
		var color: Color = shaded.get_shader_parameter("color")
		fade.tween_property(shaded, "shader_parameter/color", Color(color, 0.0), FADE_SECONDS)
	fade.tween_callback(ghost.queue_free)
