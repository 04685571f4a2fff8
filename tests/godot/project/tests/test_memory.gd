extends TestCase
## Creating and freeing many nodes must leave the engine's tracked memory and
## object count where they were, and the process's resident memory (which
## sees ONNX Runtime and std:: allocations) within
## TestCase.RESIDENT_GROWTH_BOUND. Model loads and swaps: test_lifecycle.gd.

const NODES := 5000
const MODEL_FOLDER := "res://fixtures/model"


func test_create_and_free_5000_nodes_keeps_memory_flat() -> void:
	_churn(200)  # warm caches (StringNames, method binds) before measuring
	var resident_before := resident_bytes()
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
	check_resident_growth(resident_before, "%d nodes" % NODES)


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
