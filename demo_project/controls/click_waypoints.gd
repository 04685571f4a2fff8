class_name ClickWaypoints
extends Node3D
## Left click on the ground places a waypoint (a ring) that the character
## walks to, after the ones placed before; reached rings fade; right click
## clears them.

const SPEED := 1.2
const LEAD_SECONDS := 0.8

var generator: MotionGenerator
var camera: Camera3D
## Returns the character's hips in world space.
var hips_position: Callable
var _rings: Array[MeshInstance3D] = []
var _last_point := Vector3.INF
var _last_time := 0.0


func _ready() -> void:
	generator.waypoint_reached.connect(_on_reached)


func _unhandled_input(event: InputEvent) -> void:
	var click := event as InputEventMouseButton
	if click == null or not click.pressed:
		return
	if click.button_index == MOUSE_BUTTON_RIGHT:
		clear()
	elif click.button_index == MOUSE_BUTTON_LEFT:
		var point := ground_point(click.position)
		if point != Vector3.INF:
			place(point)


## Where the ray through a screen position meets the ground (y = 0), or INF.
func ground_point(screen_position: Vector2) -> Vector3:
	var origin := camera.project_ray_origin(screen_position)
	var direction := camera.project_ray_normal(screen_position)
	if direction.y > -1e-3:
		return Vector3.INF
	return origin + direction * (-origin.y / direction.y)


## A waypoint at `point`, reached walking from the last one (or the hips).
func place(point: Vector3) -> void:
	var start: Vector3 = _last_point if _last_point != Vector3.INF else hips_position.call()
	var start_time := maxf(_last_time, generator.get_time() + LEAD_SECONDS)
	var arrival := start_time + Vector2(point.x - start.x, point.z - start.z).length() / SPEED
	generator.target_velocity = Vector3.ZERO
	generator.prompt = "walk"
	generator.add_waypoint(point, arrival)
	_last_point = point
	_last_time = arrival
	_rings.append(_ring(point))


func clear() -> void:
	generator.clear_waypoints()
	for ring in _rings:
		ring.queue_free()
	_rings.clear()
	_last_point = Vector3.INF
	_last_time = 0.0


func _ring(point: Vector3) -> MeshInstance3D:
	var torus := TorusMesh.new()
	torus.inner_radius = 0.25
	torus.outer_radius = 0.32
	var material := StandardMaterial3D.new()
	material.albedo_color = Color(0.2, 0.6, 1.0)
	material.transparency = BaseMaterial3D.TRANSPARENCY_ALPHA
	torus.material = material
	var ring := MeshInstance3D.new()
	ring.mesh = torus
	ring.position = point
	add_child(ring)
	return ring


func _on_reached(index: int) -> void:
	if index < _rings.size():
		var material: StandardMaterial3D = (_rings[index].mesh as TorusMesh).material
		material.albedo_color.a = 0.25
