extends TestCase
## Generators created, played and freed, and models swapped, while windows
## are in flight: nothing crashes, the process's resident memory stays flat
## after a warm-up (so no ONNX Runtime session, planner or thread leaks),
## and nothing is reported but what the test asks for.

const CYCLES := 200
const SHIPPED := "res://addons/ardy/models/default"
const TINY := "res://fixtures/model"
## Cycles before the resident memory is read: threads, sessions and
## allocator arenas of the first cycles settle.
const WARM_UP := 100
## Resident growth allowed over the cycles after the warm-up: above the
## allocator's noise for cycles that start threads and sessions (measured on
## 2 cores: -1.5 to +2.7 MB over 200 cycles, so TestCase.RESIDENT_GROWTH_BOUND
## is too tight here) and far below a leak in the cycle: one shipped package
## is 61-71 MB (tests/godot/harness/test_planted.gd), one tiny package per
## swap 1.2 MB x 200.
const CYCLE_RESIDENT_BOUND := 12 * 1024 * 1024


func test_create_play_and_free_while_windows_are_in_flight() -> void:
	# One character keeps the shipped model loaded, so each cycle starts at once.
	var keeper := TestCharacter.new(null, tree.root)
	keeper.recording = false
	keeper.generator.prompt = "walk"
	keeper.generator.playing = true
	check(await keeper.wait_until_generating(tree), "the shipped model loads")
	var failures: Array[String] = []
	var resident_after_warm_up := 0
	var objects_after_warm_up := 0
	for cycle in CYCLES + WARM_UP:
		if cycle == WARM_UP:
			resident_after_warm_up = resident_bytes()
			objects_after_warm_up = Performance.get_monitor(Performance.OBJECT_COUNT)
		var character := TestCharacter.new(null, tree.root)
		character.recording = false
		character.generator.generation_failed.connect(
			func(message: String) -> void: failures.append(message)
		)
		character.generator.prompt = ["walk", "run", "wave with the left hand"][cycle % 3]
		character.generator.playing = true
		for frame in 1 + cycle % 4:
			await tree.process_frame
		if cycle % 2 == 0:
			character.generator.prompt = "jump"  # a splice asked for while a window runs
		await tree.process_frame
		character.dispose()
	await tree.process_frame  # the last pose modifier frees itself
	_check_cycle_growth(resident_after_warm_up, "%d create/play/free cycles" % CYCLES)
	var objects := Performance.get_monitor(Performance.OBJECT_COUNT) - objects_after_warm_up
	print("  %d create/play/free cycles: objects %+d" % [CYCLES, objects])
	check(objects <= 0, "%d more engine objects after the cycles" % objects)
	check(failures.is_empty(), "no failures: %s" % [failures])
	keeper.dispose()


func test_model_swaps_mid_window_keep_memory_flat() -> void:
	var character := TestCharacter.new(null, tree.root)
	character.recording = false
	var generator := character.generator
	generator.prompt = "walk"
	generator.model_path = TINY
	generator.playing = true
	var loads := [0]
	generator.model_loaded.connect(func() -> void: loads[0] += 1)
	var failures: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: failures.append(message))
	check(await character.wait_until_generating(tree), "the tiny package loads and generates")
	var resident_after_warm_up := 0
	var tracked_after_warm_up := 0
	for swap in CYCLES + WARM_UP:
		if swap == WARM_UP:
			resident_after_warm_up = resident_bytes()
			tracked_after_warm_up = OS.get_static_memory_usage()
		var before: int = loads[0]
		# Two paths to the same package, so every swap is a real load.
		generator.model_path = TINY + ("/" if swap % 2 == 0 else "")
		var deadline := Time.get_ticks_msec() + 30000
		while loads[0] == before and Time.get_ticks_msec() < deadline:
			await tree.process_frame
		await tree.process_frame  # a window starts on the new model
	_check_cycle_growth(resident_after_warm_up, "%d model swaps mid-window" % CYCLES)
	var tracked := OS.get_static_memory_usage() - tracked_after_warm_up
	print("  %d model swaps mid-window: tracked memory %+d bytes" % [CYCLES, tracked])
	check_eq(loads[0], CYCLES + WARM_UP + 1, "every swap loaded")
	check(generator.is_generating(), "still generating after the swaps")
	check(tracked < 8 * 1024, "tracked memory grew by %d bytes over %d swaps" % [tracked, CYCLES])
	check(failures.is_empty(), "no failures: %s" % [failures])
	character.dispose()


func _check_cycle_growth(before: int, what: String) -> void:
	var growth := resident_bytes() - before
	print("  %s: resident memory %+.1f MB" % [what, growth / 1048576.0])
	check(
		before > 0 and growth < CYCLE_RESIDENT_BOUND,
		(
			"%s: resident memory grew by %.1f MB (bound %.0f MB)"
			% [what, growth / 1048576.0, CYCLE_RESIDENT_BOUND / 1048576.0]
		)
	)
