extends TestCase
## Creating and freeing many nodes, and swapping models again and again, must
## leave the engine's tracked memory and object count where they were.

const NODES := 5000
const SWAPS := 200
const MODEL_FOLDER := "res://fixtures/model"


func test_create_and_free_5000_nodes_keeps_memory_flat() -> void:
	_churn(200)  # warm caches (StringNames, method binds) before measuring
	var memory_before := OS.get_static_memory_usage()
	var objects_before := Performance.get_monitor(Performance.OBJECT_COUNT)
	_churn(NODES)
	var growth := OS.get_static_memory_usage() - memory_before
	var objects_after := Performance.get_monitor(Performance.OBJECT_COUNT)
	print(
		(
			"  %d nodes: tracked memory %+d bytes, objects %d -> %d"
			% [NODES, growth, objects_before, objects_after]
		)
	)
	check(growth < 8 * 1024, "tracked memory grew by %d bytes over %d nodes" % [growth, NODES])
	check_eq(objects_after, objects_before, "object count")


func test_model_swaps_keep_memory_flat() -> void:
	var generator := MotionGenerator.new()
	generator.playing = true
	tree.root.add_child(generator)
	var loads := [0]
	generator.model_loaded.connect(func() -> void: loads[0] += 1)
	# Two paths to the same package, so every swap is a real load.
	for i in 10:
		await _swap(generator, loads, i)
	var memory_before := OS.get_static_memory_usage()
	for i in SWAPS:
		await _swap(generator, loads, i)
	var growth := OS.get_static_memory_usage() - memory_before
	print("  %d model swaps: tracked memory %+d bytes" % [SWAPS, growth])
	check_eq(loads[0], SWAPS + 10, "every swap loaded")
	check(growth < 8 * 1024, "tracked memory grew by %d bytes over %d swaps" % [growth, SWAPS])
	generator.free()


func _swap(generator: MotionGenerator, loads: Array, i: int) -> void:
	var before: int = loads[0]
	generator.model_path = MODEL_FOLDER if i % 2 == 0 else MODEL_FOLDER + "/"
	var deadline := Time.get_ticks_msec() + 30000
	while loads[0] == before and Time.get_ticks_msec() < deadline:
		await tree.process_frame


func _churn(count: int) -> void:
	var parent := Node3D.new()
	tree.root.add_child(parent)
	var skeleton := Skeleton3D.new()
	skeleton.name = "Skeleton3D"
	skeleton.add_bone("Hips")
	parent.add_child(skeleton)
	for i in count:
		var generator := MotionGenerator.new()
		generator.prompt = "walk %d" % i
		generator.model_path = MODEL_FOLDER
		parent.add_child(generator)
		generator.skeleton = NodePath("../Skeleton3D")
		generator.add_waypoint(Vector3(i, 0, 1), 1.0)
		parent.remove_child(generator)
		generator.free()
	parent.free()
