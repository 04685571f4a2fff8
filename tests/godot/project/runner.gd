extends SceneTree
## Runs every test_* method of every res://tests/test_*.gd script (each a
## TestCase) and prints "PASS name" or "FAIL name: reason" per test, then
## "N passed, N failed"; the exit status is the number of failed tests.
##
## A test passes only when it ran to its end, its checks held and the engine
## reported no error during it that it did not declare (see test_case.gd).
## Errors are seen through a Logger added with OS.add_logger(), which gets
## every engine, script and push_error() error, from any thread. The last
## line before the summary, "runner: N expected engine errors", lets
## tests/godot/run.sh fail the run on any ERROR line of the engine's output
## beyond those.

## A test still running after this long is reported as hung (a guard against
## awaiting a signal that never comes; no test asserts a time).
const HANG_LIMIT_MSEC := 120000


class ErrorLogger:
	extends Logger
	## Collects the errors the engine reports, from any thread. An error that
	## the running test declared with expect_error() is only counted, so that
	## a test expecting many errors does not grow memory by collecting them.

	## The test running now, or null between tests.
	var case: TestCase
	var expected := 0
	var _mutex := Mutex.new()
	var _errors: Array[Dictionary] = []

	func _log_error(
		function: String,
		file: String,
		line: int,
		code: String,
		rationale: String,
		_editor_notify: bool,
		error_type: int,
		_script_backtraces: Array[ScriptBacktrace]
	) -> void:
		if error_type == ERROR_TYPE_WARNING:
			return
		var text := code if rationale.is_empty() else "%s (%s)" % [rationale, code]
		var where := "%s:%d in %s()" % [file, line, function]
		var script_error := error_type == ERROR_TYPE_SCRIPT
		_mutex.lock()
		if not script_error and case != null and case._consume_expected_error(text + " " + where):
			expected += 1
		else:
			_errors.append({"script": script_error, "text": text, "where": where})
		_mutex.unlock()

	## Sets the running test (null between tests).
	func set_case(running: TestCase) -> void:
		_mutex.lock()
		case = running
		_mutex.unlock()

	## The errors reported since the last call that no test expected.
	func take() -> Array[Dictionary]:
		_mutex.lock()
		var taken := _errors
		_errors = []
		_mutex.unlock()
		return taken


var _logger := ErrorLogger.new()
var _passed := 0
var _failed := 0


func _initialize() -> void:
	OS.add_logger(_logger)
	_run_all()


func _run_all() -> void:
	if not ClassDB.class_exists("MotionGenerator"):
		printerr("FAIL: the ARDY extension is not loaded")
		_finish()
		return
	_check_between_tests("before the first test")
	for file in _test_files():
		var path := "res://tests/" + file
		var script: GDScript = load(path)
		_check_between_tests("loading " + path)
		if script == null or not script.can_instantiate():
			_record(file.get_basename(), ["the script could not be loaded (see the errors above)"])
			continue
		for method in script.get_script_method_list():
			var name: String = method["name"]
			if name.begins_with("test_"):
				await _run_one(script, "%s.%s" % [file.get_basename(), name], name)
	_finish()


func _run_one(script: GDScript, title: String, method: String) -> void:
	var instance: Variant = script.new()
	if not instance is TestCase:
		_record(title, ["the script does not extend TestCase"])
		return
	var case: TestCase = instance
	case.tree = self
	Engine.print_error_messages = true
	_check_between_tests("before " + title)
	_logger.set_case(case)
	var started := Time.get_ticks_msec()
	case._run_test(method)
	while not case._finished and Time.get_ticks_msec() - started < HANG_LIMIT_MSEC:
		await process_frame
	_logger.set_case(null)
	var problems: PackedStringArray = []
	if not case._finished:
		problems.append("did not return within %d s (awaiting forever?)" % (HANG_LIMIT_MSEC / 1000))
	if not Engine.print_error_messages:
		problems.append("turned Engine.print_error_messages off (errors would go unseen)")
		Engine.print_error_messages = true
	for error in _logger.take():
		if error["script"]:
			problems.append("script error: %s at %s" % [error["text"], error["where"]])
		else:
			problems.append("unexpected engine error: %s at %s" % [error["text"], error["where"]])
	problems.append_array(case._missing_expected_errors())
	problems.append_array(case.failures)
	_record(title, problems)


func _record(title: String, problems: PackedStringArray) -> void:
	if problems.is_empty():
		_passed += 1
		print("PASS %s" % title)
		return
	_failed += 1
	for problem in problems:
		printerr("FAIL %s: %s" % [title, problem])


# Errors between tests (loading a script, the runner itself) belong to no test:
# each fails the run as a test of its own.
func _check_between_tests(when: String) -> void:
	var problems: PackedStringArray = []
	for error in _logger.take():
		problems.append(
			(
				"%s: %s at %s"
				% [
					"script error" if error["script"] else "engine error",
					error["text"],
					error["where"]
				]
			)
		)
	if not problems.is_empty():
		_record("(%s)" % when, problems)


func _finish() -> void:
	_check_between_tests("after the last test")
	if _passed + _failed == 0:
		_failed = 1
		printerr("FAIL: no test ran")
	print("runner: %d expected engine errors" % _logger.expected)
	print("%d passed, %d failed" % [_passed, _failed])
	OS.remove_logger(_logger)
	quit(mini(_failed, 125))


func _test_files() -> PackedStringArray:
	var files: PackedStringArray = []
	for file in DirAccess.get_files_at("res://tests"):
		if file.begins_with("test_") and file.ends_with(".gd"):
			files.append(file)
	files.sort()
	return files
