class_name KeyframePresets
extends Node3D
## Pose keyframes a few seconds ahead ("hands up at +2 s"): each is shown as a
## translucent ghost of the character where it will stand, until reached.

## Preset -> [pose in PoseLibrary, seconds ahead].
const PRESETS := {
	"Hands up at +2 s": ["hands up", 2.0],
	"Crouch at +3 s": ["crouch", 3.0],
	"T-pose at +2 s": ["t-pose", 2.0],
}
const GHOST_COLOR := Color(0.93, 0.42, 0.78, 0.35)
const FADE_SECONDS := 0.6
## Skeleton updates over which the character's velocity is measured (about
## a second: a step's sway averages out).
const HISTORY_UPDATES := 60
## Slower than this the character is taken to stand (its hips sway).
const STANDING_SPEED := 0.3

var generator: MotionGenerator
## The driven character's skeleton (its facing and place).
var skeleton: Skeleton3D
## Ghosts by keyframe index in the generator's list.
var _ghosts: Dictionary = {}
## The shown hips (world space) of the last updates and their motion times.
var _hips_history: Array[Vector3] = []
var _hips_times: Array[float] = []
## From the right thigh to the left one, now.
var _left := Vector3.RIGHT


func _ready() -> void:
	generator.keyframe_reached.connect(_on_reached)
	# Generated poses exist only in the skeleton's update (modifiers are not
	# kept in the bone poses): sample them there.
	skeleton.skeleton_updated.connect(_on_skeleton_updated)


## Adds the keyframe of a preset (a key of PRESETS) and shows its ghost.
func add(preset: String) -> void:
	var pose_name: String = PRESETS[preset][0]
	var seconds_ahead: float = PRESETS[preset][1]
	var ghost := Mannequin.build_ghost(GHOST_COLOR)
	ghost.name = "Ghost"
	PoseLibrary.apply(ghost, pose_name)
	generator.add_pose_keyframe(ghost, generator.get_time() + seconds_ahead)
	add_child(ghost)
	ghost.global_transform = _expected_place(seconds_ahead)
	_ghosts[generator.get_keyframes().size() - 1] = ghost


## Removes every ghost (the keyframes themselves are the generator's).
func clear() -> void:
	for ghost: Node in _ghosts.values():
		ghost.queue_free()
	_ghosts.clear()


func _on_skeleton_updated() -> void:
	_hips_history.push_back(_global_bone("Hips"))
	_hips_times.push_back(generator.get_time())
	if _hips_history.size() > HISTORY_UPDATES:
		_hips_history.pop_front()
		_hips_times.pop_front()
	_left = _global_bone("LeftUpperLeg") - _global_bone("RightUpperLeg")


# Where the character will stand in `seconds`, going on as it goes now,
# facing as it faces now.
func _expected_place(seconds: float) -> Transform3D:
	var hips: Vector3 = (
		_hips_history.back() if not _hips_history.is_empty() else skeleton.global_position
	)
	var velocity := Vector3.ZERO
	var span: float = _hips_times.back() - _hips_times.front() if _hips_times.size() > 1 else 0.0
	if span > 0.0:
		velocity = (_hips_history.back() - _hips_history.front()) / span
	velocity.y = 0
	if velocity.length() < STANDING_SPEED:
		velocity = Vector3.ZERO
	var forward := Vector3(_left.x, 0, _left.z).cross(Vector3.UP).normalized()
	var place := Vector3(hips.x, skeleton.global_position.y, hips.z) + velocity * seconds
	return Transform3D(Basis.looking_at(-forward), place)


func _global_bone(bone_name: String) -> Vector3:
	var bone := skeleton.find_bone(bone_name)
	return skeleton.global_transform * skeleton.get_bone_global_pose(bone).origin


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
