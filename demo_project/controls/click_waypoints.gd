class_name ClickWaypoints
extends Node3D
## Left click on the ground places a waypoint (a ring) that the character
## walks to, after the ones placed before, with the path to the rings still
## ahead drawn as a smooth line; reached rings fade; right click clears them.

const SPEED := 1.2
const LEAD_SECONDS := 0.8
const PATH_STEPS := 12
const PATH_HALF_WIDTH := 0.03
## Pixels a right press may move and still be a click.
const RIGHT_CLICK_SLOP := 5.0

var generator: MotionGenerator
var camera: Camera3D
## Returns the character's hips in world space.
var hips_position: Callable
var _rings: Array[MeshInstance3D] = []
## Rings not reached yet, in order.
var _ahead: Array[MeshInstance3D] = []
var _path_mesh := ImmediateMesh.new()
var _right_pressed_at := Vector2.INF
var _last_point := Vector3.INF
var _last_time := 0.0


func _ready() -> void:
	generator.waypoint_reached.connect(_on_reached)
	var path := MeshInstance3D.new()
	path.name = "Path"
	path.mesh = _path_mesh
	path.cast_shadow = GeometryInstance3D.SHADOW_CASTING_SETTING_OFF
	var material := StandardMaterial3D.new()
	material.shading_mode = BaseMaterial3D.SHADING_MODE_UNSHADED
	material.cull_mode = BaseMaterial3D.CULL_DISABLED
	material.albedo_color = Color(UiStyle.WAYPOINT, 0.8)
	material.transparency = BaseMaterial3D.TRANSPARENCY_ALPHA
	path.material_override = material
	add_child(path)


func _process(_delta: float) -> void:
	_draw_path()


func _unhandled_input(event: InputEvent) -> void:
	var click := event as InputEventMouseButton
	if click == null:
		return
	if click.button_index == MOUSE_BUTTON_RIGHT:
		# A right drag orbits the camera: only a click (released where it
		# was pressed) clears.
		if click.pressed:
			_right_pressed_at = click.position
		elif click.position.distance_to(_right_pressed_at) <= RIGHT_CLICK_SLOP:
			clear()
	elif click.button_index == MOUSE_BUTTON_LEFT and click.pressed:
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
	if start == Vector3.INF or not generator.is_generating():
		return  # no motion yet to walk from
	var start_time := maxf(_last_time, generator.get_time() + LEAD_SECONDS)
	var arrival := start_time + Vector2(point.x - start.x, point.z - start.z).length() / SPEED
	generator.target_velocity = Vector3.ZERO
	generator.prompt = "walk"
	generator.add_waypoint(point, arrival)
	_last_point = point
	_last_time = arrival
	var ring := _ring(point)
	_rings.append(ring)
	_ahead.append(ring)


func clear() -> void:
	generator.clear_waypoints()
	for ring in _rings:
		ring.queue_free()
	_rings.clear()
	_ahead.clear()
	_last_point = Vector3.INF
	_last_time = 0.0


func _ring(point: Vector3) -> MeshInstance3D:
	var torus := TorusMesh.new()
	torus.inner_radius = 0.25
	torus.outer_radius = 0.32
	var material := StandardMaterial3D.new()
	material.albedo_color = UiStyle.WAYPOINT
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
		_ahead.erase(_rings[index])


# A Catmull-Rom curve from the hips through the rings ahead, drawn as a flat
# ribbon just above the ground (a line would be one pixel wide).
func _draw_path() -> void:
	_path_mesh.clear_surfaces()
	var hips: Vector3 = hips_position.call()
	if _ahead.is_empty() or hips == Vector3.INF:
		return
	var points: Array[Vector3] = [Vector3(hips.x, 0, hips.z)]
	for ring in _ahead:
		points.append(ring.position)
	var curve: Array[Vector3] = []
	for segment in points.size() - 1:
		var before := points[maxi(segment - 1, 0)]
		var after := points[mini(segment + 2, points.size() - 1)]
		for step in PATH_STEPS:
			var along := float(step) / PATH_STEPS
			curve.append(
				points[segment].cubic_interpolate(points[segment + 1], before, after, along)
			)
	curve.append(points.back())
	_path_mesh.surface_begin(Mesh.PRIMITIVE_TRIANGLE_STRIP)
	for i in curve.size():
		var heading := curve[mini(i + 1, curve.size() - 1)] - curve[maxi(i - 1, 0)]
		var side := Vector3(-heading.z, 0, heading.x).normalized() * PATH_HALF_WIDTH
		_path_mesh.surface_add_vertex(curve[i] + side + Vector3.UP * 0.01)
		_path_mesh.surface_add_vertex(curve[i] - side + Vector3.UP * 0.01)
	_path_mesh.surface_end()
