@tool
class_name MotionTimelineGizmoPlugin
extends EditorNode3DGizmoPlugin
## Viewport gizmos of a MotionGenerator's timeline: its waypoints, paths and
## joint targets as lines with draggable handles (dragged in the horizontal
## plane at the handle's height, one undoable action per drag), and its
## keyframes as stick-figure ghosts of their poses where the generated clip
## puts the character at that time.

## Handle ids: track * TRACK_STRIDE + item * ITEM_STRIDE + path point.
const TRACK_STRIDE := 1000000
const ITEM_STRIDE := 1000
const TRACK_WAYPOINT := 0
const TRACK_PATH := 1
const TRACK_JOINT_TARGET := 2
const TRACK_NAMES: Array[String] = ["waypoint", "path point", "joint target"]

const WAYPOINT_COLOR := Color(1.0, 0.55, 0.1)
const PATH_COLOR := Color(0.2, 0.9, 1.0)
const KEYFRAME_COLOR := Color(1.0, 1.0, 1.0, 0.75)
const JOINT_TARGET_COLOR := Color(1.0, 0.25, 0.9)

const WAYPOINT_RADIUS := 0.3
const ARROW_LENGTH := 0.6
const CROSS_SIZE := 0.12
const RING_SEGMENTS := 32
## Ground-level lines are drawn this high, clear of the floor.
const LIFT := 0.02
## Half the width of the bold lines (three parallel one-pixel lines).
const BOLD := 0.008

var _undo_redo: EditorUndoRedoManager


func _init() -> void:
	create_material("waypoint", WAYPOINT_COLOR)
	create_material("path", PATH_COLOR)
	create_material("keyframe", KEYFRAME_COLOR)
	create_material("joint_target", JOINT_TARGET_COLOR)
	create_handle_material("handles")


func set_undo_redo(undo_redo: EditorUndoRedoManager) -> void:
	_undo_redo = undo_redo


func _get_gizmo_name() -> String:
	return "MotionTimeline"


func _has_gizmo(for_node_3d: Node3D) -> bool:
	return for_node_3d is MotionGenerator


func _redraw(gizmo: EditorNode3DGizmo) -> void:
	gizmo.clear()
	var generator := gizmo.get_node_3d() as MotionGenerator
	if generator == null or generator.timeline == null:
		return
	var timeline: MotionTimeline = generator.timeline
	_watch(timeline, generator)
	# Lines and handles are in the generator's space; the goals are in world.
	var to_local: Transform3D = generator.global_transform.affine_inverse()
	_draw_waypoints(gizmo, timeline, to_local)
	_draw_paths(gizmo, timeline, to_local)
	_draw_joint_targets(gizmo, timeline, to_local)
	_draw_keyframes(gizmo, timeline, to_local, generator)


func _get_handle_name(_gizmo: EditorNode3DGizmo, handle_id: int, _secondary: bool) -> String:
	var track: int = _track(handle_id)
	var index: int = _index(handle_id)
	var label: String = TRACK_NAMES[track] if track < TRACK_NAMES.size() else "handle"
	if track == TRACK_PATH:
		return "Path %d point %d" % [index, handle_id % ITEM_STRIDE]
	return "%s %d" % [label.capitalize(), index]


func _get_handle_value(gizmo: EditorNode3DGizmo, handle_id: int, _secondary: bool) -> Variant:
	var item: Resource = _item(gizmo, handle_id)
	if item == null:
		return Vector3.ZERO
	if _track(handle_id) == TRACK_PATH:
		var points: PackedVector3Array = item.get("points")
		var point: int = handle_id % ITEM_STRIDE
		return points[point] if point < points.size() else Vector3.ZERO
	var position: Vector3 = item.get("position")
	return position


func _set_handle(
	gizmo: EditorNode3DGizmo, handle_id: int, secondary: bool, camera: Camera3D, screen_pos: Vector2
) -> void:
	var item: Resource = _item(gizmo, handle_id)
	if item == null:
		return
	var current: Vector3 = _get_handle_value(gizmo, handle_id, secondary)
	var plane := Plane(Vector3.UP, current.y)
	var origin: Vector3 = camera.project_ray_origin(screen_pos)
	var normal: Vector3 = camera.project_ray_normal(screen_pos)
	var hit: Variant = plane.intersects_ray(origin, normal)
	if hit == null:
		return
	var target: Vector3 = hit
	target.y = current.y
	_write(item, handle_id, target)


func _commit_handle(
	gizmo: EditorNode3DGizmo, handle_id: int, secondary: bool, restore: Variant, cancel: bool
) -> void:
	var item: Resource = _item(gizmo, handle_id)
	if item == null:
		return
	var before: Vector3 = restore
	if cancel:
		_write(item, handle_id, before)
		return
	var node: Node3D = gizmo.get_node_3d()
	if _undo_redo == null:
		node.update_gizmos()
		return
	var track: int = _track(handle_id)
	if track == TRACK_PATH:
		var points: PackedVector3Array = (item.get("points") as PackedVector3Array).duplicate()
		var old_points: PackedVector3Array = points.duplicate()
		var point: int = handle_id % ITEM_STRIDE
		if point < old_points.size():
			old_points[point] = before
		_undo_redo.create_action("Move path point", UndoRedo.MERGE_DISABLE, node)
		_undo_redo.add_do_property(item, "points", points)
		_undo_redo.add_undo_property(item, "points", old_points)
	else:
		var after: Vector3 = _get_handle_value(gizmo, handle_id, secondary)
		var action: String = "Move waypoint" if track == TRACK_WAYPOINT else "Move joint target"
		_undo_redo.create_action(action, UndoRedo.MERGE_DISABLE, node)
		_undo_redo.add_do_property(item, "position", after)
		_undo_redo.add_undo_property(item, "position", before)
	_undo_redo.add_do_method(node, "update_gizmos")
	_undo_redo.add_undo_method(node, "update_gizmos")
	_undo_redo.commit_action()


@warning_ignore("integer_division")
func _track(handle_id: int) -> int:
	return handle_id / TRACK_STRIDE


@warning_ignore("integer_division")
func _index(handle_id: int) -> int:
	return (handle_id % TRACK_STRIDE) / ITEM_STRIDE


# Redraws the node when the timeline or one of its items changes (each
# connected once, when first seen).
func _watch(timeline: MotionTimeline, node: Node3D) -> void:
	var redraw: Callable = node.update_gizmos
	var resources: Array[Resource] = [timeline]
	for list: Array in [timeline.waypoints, timeline.paths, timeline.keyframes]:
		for item: Resource in list:
			resources.append(item)
	for item: Resource in timeline.joint_targets:
		resources.append(item)
	for resource: Resource in resources:
		if resource != null and not resource.changed.is_connected(redraw):
			resource.changed.connect(redraw)


# The item resource a handle id points at (null when it is gone).
func _item(gizmo: EditorNode3DGizmo, handle_id: int) -> Resource:
	var generator := gizmo.get_node_3d() as MotionGenerator
	if generator == null or generator.timeline == null:
		return null
	var track: int = _track(handle_id)
	var index: int = _index(handle_id)
	var list: Array = []
	match track:
		TRACK_WAYPOINT:
			list = generator.timeline.waypoints
		TRACK_PATH:
			list = generator.timeline.paths
		TRACK_JOINT_TARGET:
			list = generator.timeline.joint_targets
	if index >= list.size():
		return null
	return list[index] as Resource


# Sets the handle's position on its item (the resource emits `changed`).
func _write(item: Resource, handle_id: int, value: Vector3) -> void:
	if _track(handle_id) == TRACK_PATH:
		var points: PackedVector3Array = (item.get("points") as PackedVector3Array).duplicate()
		var point: int = handle_id % ITEM_STRIDE
		if point >= points.size():
			return
		points[point] = value
		item.set("points", points)
	else:
		item.set("position", value)


func _draw_waypoints(
	gizmo: EditorNode3DGizmo, timeline: MotionTimeline, to_local: Transform3D
) -> void:
	var lines := PackedVector3Array()
	var handles := PackedVector3Array()
	var ids := PackedInt32Array()
	for i: int in timeline.waypoints.size():
		var waypoint: MotionWaypoint = timeline.waypoints[i]
		if waypoint == null:
			continue
		var centre: Vector3 = waypoint.position
		var drawn: Vector3 = centre + Vector3.UP * LIFT
		_add_ring(lines, drawn, WAYPOINT_RADIUS)
		var r: float = WAYPOINT_RADIUS * 0.5
		_add_segment(lines, drawn + Vector3(-r, 0, 0), drawn + Vector3(r, 0, 0))
		_add_segment(lines, drawn + Vector3(0, 0, -r), drawn + Vector3(0, 0, r))
		if waypoint.use_heading:
			_add_arrow(lines, drawn, Vector3(sin(waypoint.heading), 0, cos(waypoint.heading)))
		handles.append(to_local * centre)
		ids.append(TRACK_WAYPOINT * TRACK_STRIDE + i * ITEM_STRIDE)
	_add(gizmo, lines, handles, ids, "waypoint", to_local)


func _draw_paths(gizmo: EditorNode3DGizmo, timeline: MotionTimeline, to_local: Transform3D) -> void:
	var lines := PackedVector3Array()
	var handles := PackedVector3Array()
	var ids := PackedInt32Array()
	for i: int in timeline.paths.size():
		var path: MotionPath = timeline.paths[i]
		if path == null:
			continue
		var points: PackedVector3Array = path.points
		for p: int in points.size():
			if p > 0:
				_add_segment(
					lines, points[p - 1] + Vector3.UP * LIFT, points[p] + Vector3.UP * LIFT
				)
			handles.append(to_local * points[p])
			ids.append(TRACK_PATH * TRACK_STRIDE + i * ITEM_STRIDE + p)
		if points.size() >= 2:
			var last: int = points.size() - 1
			var direction: Vector3 = points[last] - points[last - 1]
			direction.y = 0.0
			if direction.length() > 0.001:
				var end: Vector3 = points[last] + Vector3.UP * LIFT
				_add_arrow(lines, end - direction.normalized() * ARROW_LENGTH, direction)
	_add(gizmo, lines, handles, ids, "path", to_local)


func _draw_joint_targets(
	gizmo: EditorNode3DGizmo, timeline: MotionTimeline, to_local: Transform3D
) -> void:
	var lines := PackedVector3Array()
	var handles := PackedVector3Array()
	var ids := PackedInt32Array()
	var ground_y: float = to_local.affine_inverse().origin.y
	for i: int in timeline.joint_targets.size():
		var target: MotionJointTarget = timeline.joint_targets[i]
		if target == null or not target.use_position:
			continue
		var p: Vector3 = target.position
		for axis: Vector3 in [Vector3.RIGHT, Vector3.UP, Vector3.BACK]:
			_add_segment(lines, p - axis * CROSS_SIZE, p + axis * CROSS_SIZE)
		# A thin stem down to the character's ground shows where it is over the floor.
		var ground: Vector3 = Vector3(p.x, ground_y + LIFT, p.z)
		lines.append_array([p, ground])
		lines.append_array(_ring(ground, CROSS_SIZE * 0.5))
		handles.append(to_local * p)
		ids.append(TRACK_JOINT_TARGET * TRACK_STRIDE + i * ITEM_STRIDE)
	_add(gizmo, lines, handles, ids, "joint_target", to_local)


func _draw_keyframes(
	gizmo: EditorNode3DGizmo,
	timeline: MotionTimeline,
	to_local: Transform3D,
	generator: MotionGenerator
) -> void:
	var skeleton := generator.get_node_or_null(generator.skeleton) as Skeleton3D
	if skeleton == null or skeleton.get_bone_count() == 0:
		return
	var lines := PackedVector3Array()
	for keyframe: MotionKeyframe in timeline.keyframes:
		if keyframe == null:
			continue
		var place: Transform3D = skeleton.global_transform
		var root: Variant = generator.get_clip_root(keyframe.time)
		if root is Transform3D:
			place = root
		var bones: Array[Transform3D] = _pose_globals(skeleton, keyframe.pose)
		for bone: int in bones.size():
			var parent: int = skeleton.get_bone_parent(bone)
			if parent >= 0:
				_add_segment(lines, place * bones[parent].origin, place * bones[bone].origin)
		# The ground point and facing of the ghost.
		var ground: Vector3 = place.origin + Vector3.UP * LIFT
		lines.append_array(_ring(ground, 0.15))
		lines.append(ground)
		lines.append(ground + place.basis.z.normalized() * 0.3)
	_add(gizmo, lines, PackedVector3Array(), PackedInt32Array(), "keyframe", to_local)


# Skeleton-space transforms of every bone: the rests, with the pose's local
# rotations (bone name -> Quaternion) in place of the rest rotations.
func _pose_globals(skeleton: Skeleton3D, pose: Dictionary) -> Array[Transform3D]:
	var count: int = skeleton.get_bone_count()
	var globals: Array[Transform3D] = []
	globals.resize(count)
	var done := PackedByteArray()
	done.resize(count)
	for bone: int in count:
		_pose_global(skeleton, pose, bone, globals, done)
	return globals


func _pose_global(
	skeleton: Skeleton3D,
	pose: Dictionary,
	bone: int,
	globals: Array[Transform3D],
	done: PackedByteArray
) -> Transform3D:
	if done[bone] != 0:
		return globals[bone]
	var local: Transform3D = skeleton.get_bone_rest(bone)
	var bone_name: String = skeleton.get_bone_name(bone)
	if pose.has(bone_name) and pose[bone_name] is Quaternion:
		var rotation: Quaternion = pose[bone_name]
		local = Transform3D(
			Basis(rotation.normalized()).scaled(local.basis.get_scale()), local.origin
		)
	var parent: int = skeleton.get_bone_parent(bone)
	var result: Transform3D = local
	if parent >= 0:
		result = _pose_global(skeleton, pose, parent, globals, done) * local
	globals[bone] = result
	done[bone] = 1
	return result


# A horizontal circle, as line segments.
func _ring(centre: Vector3, radius: float) -> PackedVector3Array:
	var lines := PackedVector3Array()
	for s: int in RING_SEGMENTS:
		var a: float = TAU * s / RING_SEGMENTS
		var b: float = TAU * (s + 1) / RING_SEGMENTS
		lines.append(centre + Vector3(cos(a), 0, sin(a)) * radius)
		lines.append(centre + Vector3(cos(b), 0, sin(b)) * radius)
	return lines


# A bold horizontal circle: three close ones.
func _add_ring(lines: PackedVector3Array, centre: Vector3, radius: float) -> void:
	for offset: float in [-BOLD, 0.0, BOLD]:
		lines.append_array(_ring(centre, radius + offset))


# A bold segment (gizmo lines are one pixel wide): three close parallel lines.
func _add_segment(lines: PackedVector3Array, start: Vector3, end: Vector3) -> void:
	var along: Vector3 = end - start
	var side: Vector3 = along.cross(Vector3.UP)
	if side.length() < 0.0001:
		side = Vector3.RIGHT
	side = side.normalized() * BOLD
	for offset: Vector3 in [-side, Vector3.ZERO, side]:
		lines.append(start + offset)
		lines.append(end + offset)


func _add_arrow(lines: PackedVector3Array, start: Vector3, direction: Vector3) -> void:
	var forward: Vector3 = direction.normalized()
	var side: Vector3 = forward.cross(Vector3.UP).normalized()
	var tip: Vector3 = start + forward * ARROW_LENGTH
	var barb: float = ARROW_LENGTH * 0.3
	_add_segment(lines, start, tip)
	_add_segment(lines, tip, tip - forward * barb + side * barb * 0.6)
	_add_segment(lines, tip, tip - forward * barb - side * barb * 0.6)


# Adds world-space lines and local handles with the named material.
func _add(
	gizmo: EditorNode3DGizmo,
	lines: PackedVector3Array,
	handles: PackedVector3Array,
	ids: PackedInt32Array,
	material_name: String,
	to_local: Transform3D
) -> void:
	if not lines.is_empty():
		var local_lines := PackedVector3Array()
		local_lines.resize(lines.size())
		for i: int in lines.size():
			local_lines[i] = to_local * lines[i]
		gizmo.add_lines(local_lines, get_material(material_name, gizmo))
	if not handles.is_empty():
		gizmo.add_handles(handles, get_material("handles", gizmo), ids)
