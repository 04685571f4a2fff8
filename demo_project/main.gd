extends Node3D
## Demo entry point. For now it shows whether the ARDY extension and the
## shipped default model load; the playable demo (prompts, clicks, keys)
## replaces it.

const DEFAULT_MODEL := "res://addons/ardy/models/default"

@onready var status_label: Label = $UI/Status


func _ready() -> void:
	var loaded := ClassDB.class_exists("MotionGenerator")
	var lines: PackedStringArray = []
	if loaded:
		lines.append("ARDY extension loaded: MotionGenerator is available.")
		var model_line := _load_default_model()
		loaded = not model_line.begins_with("NOT")
		lines.append(model_line)
	else:
		lines.append("ARDY extension NOT loaded: build it with scripts/demo.sh.")
	var message := "\n".join(lines)
	status_label.text = message
	if loaded:
		print(message)
	else:
		printerr(message)
	if DisplayServer.get_name() == "headless":
		get_tree().quit(0 if loaded else 1)


func _load_default_model() -> String:
	var generator: Node = ClassDB.instantiate("MotionGenerator")
	add_child(generator)
	var ok: bool = generator.call("load_model", DEFAULT_MODEL)
	var line := (
		(
			"Default model loaded: %d joints, graphs %s."
			% [generator.call("get_joint_names").size(), generator.call("get_loaded_graphs")]
		)
		if ok
		else "NOT loaded: the default model (%s)" % generator.call("get_last_error")
	)
	generator.queue_free()
	return line
