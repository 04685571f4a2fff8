extends Node3D
## Demo entry point. For now it shows whether the ARDY extension loaded; the
## playable demo (prompts, clicks, keys) replaces it.

@onready var status_label: Label = $UI/Status


func _ready() -> void:
	var loaded := ClassDB.class_exists("MotionGenerator")
	var message := (
		"ARDY extension loaded: MotionGenerator is available."
		if loaded
		else "ARDY extension NOT loaded: build it with scripts/demo.sh."
	)
	status_label.text = message
	if loaded:
		print(message)
	else:
		printerr(message)
	if DisplayServer.get_name() == "headless":
		get_tree().quit(0 if loaded else 1)
