extends SceneTree
## Runs every test_* method of every res://tests/test_*.gd script and prints
## "N passed, N failed"; the exit status is the number of failed tests.
## Tests may await frames (tree.process_frame).


func _initialize() -> void:
	_run_all()


func _run_all() -> void:
	var passed := 0
	var failed := 0
	if not ClassDB.class_exists("MotionGenerator"):
		printerr("FAIL: the ARDY extension is not loaded")
		print("0 passed, 1 failed")
		quit(1)
		return
	for file in _test_files():
		var script: GDScript = load("res://tests/" + file)
		for method in script.get_script_method_list():
			var name: String = method["name"]
			if not name.begins_with("test_"):
				continue
			var case: TestCase = script.new()
			case.tree = self
			await case.call(name)
			if case.failures.is_empty():
				passed += 1
				print("PASS %s.%s" % [file.get_basename(), name])
			else:
				failed += 1
				for failure in case.failures:
					printerr("FAIL %s.%s: %s" % [file.get_basename(), name, failure])
	print("%d passed, %d failed" % [passed, failed])
	quit(mini(failed, 125))


func _test_files() -> PackedStringArray:
	var files: PackedStringArray = []
	for file in DirAccess.get_files_at("res://tests"):
		if file.begins_with("test_") and file.ends_with(".gd"):
			files.append(file)
	files.sort()
	return files
