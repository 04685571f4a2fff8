@tool
extends EditorPlugin
## The addon's editor side: the export plugin that packs the model packages
## into exported games, the "Motion Timeline" bottom panel for the selected
## MotionGenerator, and the viewport gizmos of its timeline's goals.

const TimelineDock := preload("res://addons/ardy/editor/timeline_dock.gd")
const TimelineGizmoPlugin := preload("res://addons/ardy/editor/timeline_gizmo_plugin.gd")

var _export_plugin: EditorExportPlugin
var _dock: TimelineDock
var _gizmo_plugin: TimelineGizmoPlugin


func _enter_tree() -> void:
	_export_plugin = preload("res://addons/ardy/model_export_plugin.gd").new()
	add_export_plugin(_export_plugin)
	_gizmo_plugin = TimelineGizmoPlugin.new()
	_gizmo_plugin.set_undo_redo(get_undo_redo())
	add_node_3d_gizmo_plugin(_gizmo_plugin)
	_dock = TimelineDock.new()
	_dock.name = "MotionTimelineDock"
	_dock.set_undo_redo(get_undo_redo())
	add_control_to_bottom_panel(_dock, "Motion Timeline")


func _exit_tree() -> void:
	remove_export_plugin(_export_plugin)
	_export_plugin = null
	remove_node_3d_gizmo_plugin(_gizmo_plugin)
	_gizmo_plugin = null
	remove_control_from_bottom_panel(_dock)
	_dock.queue_free()
	_dock = null


func _handles(object: Object) -> bool:
	return object is MotionGenerator


func _edit(object: Object) -> void:
	_dock.edit(object as Node)


func _make_visible(visible: bool) -> void:
	if visible:
		make_bottom_panel_item_visible(_dock)
