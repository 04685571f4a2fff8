extends SceneTree
## Exits 0 when the extension is loaded (MotionGenerator is registered).


func _initialize() -> void:
	quit(0 if ClassDB.class_exists("MotionGenerator") else 3)
