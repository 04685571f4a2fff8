extends TestCase
## Planted tests for the harness's own test (tests/godot/check_harness.py):
## tests/godot/run.sh copies the engine-test project, replaces its tests with
## this script and runs runner.gd on it. Each test states the outcome the
## runner must give it; never part of the real suite.

const DEFAULT_MODEL := "res://addons/ardy/models/default"
const TINY_MODEL := "res://fixtures/model"
const LOADS := 20

# Holds the planted leaks until the process exits.
static var _leaked: Array[Node] = []


# PASS: checks that hold, arrays of two kinds compared by elements.
func test_pass_plain() -> void:
	check(true, "holds")
	check_eq(PackedStringArray(["Hips", "Spine"]), ["Hips", "Spine"], "joint names")
	await tree.process_frame
	check_eq(1, 1.0, "an int and a float")


# PASS: an engine error that the test declared.
func test_pass_expected_error() -> void:
	expect_error("res://fixtures/missing/model.json")
	var generator: MotionGenerator = await _load("res://fixtures/missing")
	check(not generator.is_model_loaded(), "a missing model is refused")
	generator.free()


# FAIL (script error): the test stops at the error and reaches no check.
func test_fail_script_error() -> void:
	var nothing: Variant = null
	nothing.reset()
	check(true, "never reached")


# FAIL (script error): the same after an await, in the resumed coroutine.
func test_fail_script_error_after_await() -> void:
	await tree.process_frame
	var values: Array[int] = [1, 2]
	check_eq(values[5], 3, "never reached")


# FAIL (unexpected engine error): push_error() that the test did not declare.
func test_fail_unexpected_error() -> void:
	push_error("planted error")


# FAIL (unexpected engine error): an error reported from another thread.
func test_fail_error_from_a_thread() -> void:
	var thread := Thread.new()
	thread.start(func() -> void: push_error("planted error from a thread"))
	thread.wait_to_finish()


# FAIL (expected error not reported): a declared error that never comes.
func test_fail_missing_expected_error() -> void:
	expect_error("an error that never comes")


# FAIL (check): a failed check, and a comparison of incomparable types.
func test_fail_check() -> void:
	check(false, "planted failed check")
	check_eq(PackedStringArray(["Hips"]), 1, "incomparable")


# FAIL (resident memory): one shipped default package leaked among LOADS loads
# of the tiny one; the engine's own counter grows by a node, far below its bound.
func test_fail_leaked_default_package() -> void:
	await _leak_one(DEFAULT_MODEL)


# FAIL (resident memory): the same with the tiny test package.
func test_fail_leaked_tiny_package() -> void:
	await _leak_one(TINY_MODEL)


# A generator in the tree with the model at `path`, once it has loaded (or failed).
func _load(path: String) -> MotionGenerator:
	var generator := MotionGenerator.new()
	generator.model_path = path
	generator.playing = true
	tree.root.add_child(generator)
	while not generator.is_model_loaded() and generator.get_last_error().is_empty():
		await tree.process_frame
	return generator


func _leak_one(path: String) -> void:
	(await _load(TINY_MODEL)).free()  # warm up, as test_lifecycle.gd does
	var resident_before := resident_bytes()
	var memory_before := OS.get_static_memory_usage()
	for i in LOADS:
		(await _load(TINY_MODEL)).free()
	var leaked: MotionGenerator = await _load(path)
	check(leaked.is_model_loaded(), "the leaked package loads: " + leaked.get_last_error())
	tree.root.remove_child(leaked)  # an orphan node holding its package: the leak
	_leaked.append(leaked)
	var growth := OS.get_static_memory_usage() - memory_before
	print("  planted leak of %s: tracked memory %+d bytes" % [path, growth])
	check(growth < 8 * 1024, "tracked memory grew by %d bytes" % growth)
	check_resident_growth(resident_before, "%d loads and one leaked package" % LOADS)
