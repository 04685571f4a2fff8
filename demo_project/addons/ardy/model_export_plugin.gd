@tool
extends EditorExportPlugin
## Packs every file of the model packages under res://addons/ardy/models
## (the ONNX graphs, model.json, the vocabulary, LICENSE.md and the model
## card) into exported games: they are not Godot resources, so an export
## preset's resource filter would leave them out.

const MODELS := "res://addons/ardy/models"


func _get_name() -> String:
	return "ARDY model packages"


func _export_begin(
	_features: PackedStringArray, _is_debug: bool, _path: String, _flags: int
) -> void:
	for file in _files_under(MODELS):
		add_file(file, FileAccess.get_file_as_bytes(file), false)


func _files_under(folder: String) -> PackedStringArray:
	var files: PackedStringArray = []
	for file in DirAccess.get_files_at(folder):
		if not file.ends_with(".import") and not file.ends_with(".uid"):
			files.append(folder.path_join(file))
	for sub in DirAccess.get_directories_at(folder):
		files.append_array(_files_under(folder.path_join(sub)))
	return files
