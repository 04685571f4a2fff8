extends Node
## Main scene of the exported .pck: proves that the packed game loads the
## extension and reads a model graph, the tiny test package and the shipped
## default model from res:// inside the pack.

const DEFAULT_MODEL := "res://addons/ardy/models/default"

var passed := 0
var failed := 0


func _ready() -> void:
	_check(
		ClassDB.class_exists("MotionGenerator"), "the extension is loaded from the exported pack"
	)
	_check(FileAccess.file_exists("res://fixtures/mlp.onnx"), "the graph is inside the pack")
	_check(
		not FileAccess.file_exists("res://tests/test_memory.gd"),
		"the export filter left the tests out"
	)
	if ClassDB.class_exists("MotionGenerator"):
		var generator: Node = ClassDB.instantiate("MotionGenerator")
		var loaded: bool = generator.call("load_model", "res://fixtures/mlp.onnx")
		_check(
			loaded,
			"load_model reads the graph from the pack: " + str(generator.call("get_last_error"))
		)
		loaded = generator.call("load_model", "res://fixtures/model")
		_check(
			loaded,
			(
				"load_model reads a model package from the pack: "
				+ str(generator.call("get_last_error"))
			)
		)
		loaded = generator.call("load_model", DEFAULT_MODEL)
		_check(
			loaded and generator.call("get_joint_names").size() == 21,
			(
				"load_model reads the shipped default model from the pack: "
				+ str(generator.call("get_last_error"))
			)
		)
		generator.free()
	print("%d passed, %d failed" % [passed, failed])
	get_tree().quit(failed)


func _check(condition: bool, what: String) -> void:
	if condition:
		passed += 1
		print("PASS pack: " + what)
	else:
		failed += 1
		printerr("FAIL pack: " + what)
