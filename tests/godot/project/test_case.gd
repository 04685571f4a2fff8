class_name TestCase
extends RefCounted
## Base of every engine test script: methods named test_* are run by
## runner.gd; check() records a failure with its message.

var failures: PackedStringArray = []
var tree: SceneTree


func check(condition: bool, message: String) -> void:
	if not condition:
		failures.append(message)


func check_eq(found: Variant, expected: Variant, what: String) -> void:
	check(found == expected, "%s: expected %s, found %s" % [what, expected, found])
