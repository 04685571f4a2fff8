extends Node
## Main scene of the exported .pck: proves that the packed game loads the
## extension and generates motion with the shipped default model read from
## res:// inside the pack.

var passed := 0
var failed := 0


func _ready() -> void:
	_check(
		ClassDB.class_exists("MotionGenerator"), "the extension is loaded from the exported pack"
	)
	for file in ["denoiser.onnx", "model.json", "vocab.txt", "LICENSE.md"]:
		_check(
			FileAccess.file_exists(TestCharacter.MODEL.path_join(file)),
			"the addon's export plugin packed the shipped model's " + file
		)
	_check(
		not FileAccess.file_exists("res://tests/test_memory.gd"),
		"the export filter left the tests out"
	)
	if ClassDB.class_exists("MotionGenerator"):
		await _generate()
	print("%d passed, %d failed" % [passed, failed])
	get_tree().quit(failed)


func _generate() -> void:
	var character := TestCharacter.new(null, self)
	character.generator.prompt = "walk forward"
	character.generator.playing = true
	var started: bool = await character.wait_until_generating(get_tree())
	_check(started, "the model loads from the pack: " + character.generator.get_last_error())
	if not started:
		return
	await character.wait_until_time(get_tree(), 2.0)
	var moved := character.position_at("Hips", 0.05).distance_to(character.last_position("Hips"))
	print("pack: the hips moved %.2f m in 2 s" % moved)
	_check(moved > 0.5, "the packed game generates motion: the hips moved %.2f m in 2 s" % moved)
	character.dispose()


func _check(condition: bool, what: String) -> void:
	if condition:
		passed += 1
		print("PASS pack: " + what)
	else:
		failed += 1
		printerr("FAIL pack: " + what)
