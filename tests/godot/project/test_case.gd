class_name TestCase
extends RefCounted
## Base of every engine test script. runner.gd runs each method named test_*
## on a fresh instance of its script; a test may await frames
## ([code]await tree.process_frame[/code]).
##
## A test passes only when all of these hold:
## - it ran to its end: a script error (a call on null, a bad index, a failed
##   assert) stops the method, and the runner counts the script error as a
##   failure; a test that never returns fails when the runner gives up on it;
## - every check() and check_eq() held;
## - the engine reported no error during the test (push_error(), an engine
##   "ERROR:", a script error, also from other threads) that the test did not
##   declare with expect_error() first;
## - every error declared with expect_error() was reported as many times as
##   declared.
##
## Tests that provoke engine errors on purpose declare them before provoking:
## [codeblock]
## func test_missing_model_is_reported() -> void:
##     expect_error("missing.onnx")  # one error whose text contains this
##     check(not generator.load_model("res://fixtures/missing.onnx"), "refused")
##
## func test_many_failed_loads() -> void:
##     expect_error("missing.onnx", LOADS)  # exactly LOADS such errors
## [/codeblock]
## An error matches a declaration when its message (or the engine's
## explanation, or its source file) contains the substring; each error
## consumes one count of the first declaration it matches that still has
## counts left. Script errors can never be declared: they always fail.
## Warnings are not errors and are ignored.
##
## Memory: resident_bytes() is the process's resident memory (RSS), which sees
## native allocations (ONNX Runtime sessions, std:: containers) that the
## engine's OS.get_static_memory_usage() does not; check_resident_growth()
## fails the test when it grew by more than RESIDENT_GROWTH_BOUND since a
## reading taken after a warm-up:
## [codeblock]
## work()  # warm up: caches, arenas, thread pools
## var resident_before := resident_bytes()
## for i in 200:
##     work()
## check_resident_growth(resident_before, "200 loads")
## [/codeblock]

## Growth of resident memory that counts as a leak. Measured on the design
## machine (tests/godot/harness/test_planted.gd, test_memory.gd): one leaked
## tiny test package (res://fixtures/model) holds 1.2-2.4 MB, the shipped
## default package 71 MB (the engine's own counter sees 1.6 kB of either);
## 5000 nodes or 200 model loads after a warm-up move it by 64-128 kB. 768 kB
## sits 1.5 times below the smallest package and 6 times above the noise.
const RESIDENT_GROWTH_BOUND := 768 * 1024

var failures: PackedStringArray = []
var tree: SceneTree

var _expected: Array[Dictionary] = []
var _finished := false


func check(condition: bool, message: String) -> void:
	if not condition:
		failures.append(message)


## Arrays of any kind (Array, PackedStringArray, ...) compare by their
## elements; values of types that cannot be compared fail the check instead of
## stopping the test with a script error.
func check_eq(found: Variant, expected: Variant, what: String) -> void:
	if not _comparable(found, expected):
		check(
			false,
			(
				"%s: expected %s (%s), found %s (%s)"
				% [what, expected, type_string(typeof(expected)), found, type_string(typeof(found))]
			)
		)
		return
	if _is_array(found) and _is_array(expected):
		found = Array(found)
		expected = Array(expected)
	check(found == expected, "%s: expected %s, found %s" % [what, expected, found])


## Declares that the engine will report [param count] errors whose text
## contains [param substring] during this test (see the class description).
func expect_error(substring: String, count: int = 1) -> void:
	_expected.append({"substring": substring, "count": count, "seen": 0})


## The process's resident memory in bytes (VmRSS of /proc/self/status), or -1
## where it cannot be read.
static func resident_bytes() -> int:
	var file := FileAccess.open("/proc/self/status", FileAccess.READ)
	if file == null:
		return -1
	while not file.eof_reached():
		var line := file.get_line()
		if line.begins_with("VmRSS:"):
			return int(line.get_slice(":", 1).strip_edges().get_slice(" ", 0)) * 1024
	return -1


## Fails the test when resident memory grew by more than RESIDENT_GROWTH_BOUND
## since [param before] (a resident_bytes() reading); returns the growth.
func check_resident_growth(before: int, what: String) -> int:
	var after := resident_bytes()
	check(before > 0 and after > 0, "%s: resident memory could not be read" % what)
	var growth := after - before
	print("  %s: resident memory %+d bytes" % [what, growth])
	check(
		growth <= RESIDENT_GROWTH_BOUND,
		(
			"%s: resident memory grew by %d bytes (bound %d): native memory leaked"
			% [what, growth, RESIDENT_GROWTH_BOUND]
		)
	)
	return growth


static func _is_array(value: Variant) -> bool:
	return (
		typeof(value) == TYPE_ARRAY
		or (typeof(value) >= TYPE_PACKED_BYTE_ARRAY and typeof(value) <= TYPE_PACKED_VECTOR4_ARRAY)
	)


static func _comparable(a: Variant, b: Variant) -> bool:
	var ta := typeof(a)
	var tb := typeof(b)
	if ta == tb or ta == TYPE_NIL or tb == TYPE_NIL or (_is_array(a) and _is_array(b)):
		return true
	var numbers := [TYPE_INT, TYPE_FLOAT]
	var strings := [TYPE_STRING, TYPE_STRING_NAME]
	return (ta in numbers and tb in numbers) or (ta in strings and tb in strings)


# Called by runner.gd: runs one test method and marks its end.
func _run_test(method: StringName) -> void:
	await call(method)
	_finished = true


# Called by runner.gd for each error the engine reports during this test:
# true when a declaration of expect_error() accounts for it.
func _consume_expected_error(text: String) -> bool:
	for expectation in _expected:
		if expectation["seen"] < expectation["count"] and text.contains(expectation["substring"]):
			expectation["seen"] += 1
			return true
	return false


# Called by runner.gd after the test: the declared errors that did not come.
func _missing_expected_errors() -> PackedStringArray:
	var missing: PackedStringArray = []
	for expectation in _expected:
		if expectation["seen"] != expectation["count"]:
			missing.append(
				(
					'expected %d error(s) containing "%s", the engine reported %d'
					% [expectation["count"], expectation["substring"], expectation["seen"]]
				)
			)
	return missing
