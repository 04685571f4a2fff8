extends TestCase
## Generators created, played and freed, and models swapped, while windows
## are in flight: nothing crashes, the process's resident memory stays flat
## after a warm-up (so no ONNX Runtime session, planner or thread leaks),
## and nothing is reported but what the test asks for.

const CYCLES := 200
const SHIPPED := "res://addons/ardy/models/default"
const TINY := "res://fixtures/model"
## Resident growth allowed over the cycles after the warm-up. One leaked
## planner with its frames is about 1 MB; one leaked shipped package is far
## more than this.
const RESIDENT_BOUND := 24 * 1024 * 1024


func _resident_bytes() -> int:
	# /proc files have no length, so read the line rather than the whole file.
	var fields := FileAccess.open("/proc/self/statm", FileAccess.READ).get_line().split(" ")
	return int(fields[1]) * 4096


func test_create_play_and_free_while_windows_are_in_flight() -> void:
	# One character keeps the shipped model loaded, so each cycle starts at once.
	var keeper := TestCharacter.new(null, tree.root)
	keeper.generator.prompt = "walk"
	keeper.generator.playing = true
	check(await keeper.wait_until_generating(tree), "the shipped model loads")
	var failures: Array[String] = []
	var resident_after_warm_up := 0
	for cycle in CYCLES + 20:
		if cycle == 20:
			resident_after_warm_up = _resident_bytes()
		var character := TestCharacter.new(null, tree.root)
		character.generator.generation_failed.connect(func(message: String) -> void: failures.append(message))
		character.generator.prompt = ["walk", "run", "wave with the left hand"][cycle % 3]
		character.generator.playing = true
		for frame in 1 + cycle % 4:
			await tree.process_frame
		if cycle % 2 == 0:
			character.generator.prompt = "jump"  # a splice asked for while a window runs
		await tree.process_frame
		character.dispose()
	var growth := _resident_bytes() - resident_after_warm_up
	print("  %d create/play/free cycles: resident memory %+.1f MB" % [CYCLES, growth / 1048576.0])
	check(growth < RESIDENT_BOUND, "resident memory grew by %.1f MB over %d cycles" % [growth / 1048576.0, CYCLES])
	check(failures.is_empty(), "no failures: %s" % [failures])
	keeper.dispose()


func test_model_swaps_mid_window_keep_memory_flat() -> void:
	var character := TestCharacter.new(null, tree.root)
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
	for swap in CYCLES + 20:
		if swap == 20:
			resident_after_warm_up = _resident_bytes()
		var before: int = loads[0]
		# Two paths to the same package, so every swap is a real load.
		generator.model_path = TINY + ("/" if swap % 2 == 0 else "")
		var deadline := Time.get_ticks_msec() + 30000
		while loads[0] == before and Time.get_ticks_msec() < deadline:
			await tree.process_frame
		await tree.process_frame  # a window starts on the new model
	var growth := _resident_bytes() - resident_after_warm_up
	print("  %d model swaps mid-window: resident memory %+.1f MB" % [CYCLES, growth / 1048576.0])
	check_eq(loads[0], CYCLES + 21, "every swap loaded")
	check(generator.is_generating(), "still generating after the swaps")
	check(growth < RESIDENT_BOUND, "resident memory grew by %.1f MB over %d swaps" % [growth / 1048576.0, CYCLES])
	check(failures.is_empty(), "no failures: %s" % [failures])
	character.dispose()
