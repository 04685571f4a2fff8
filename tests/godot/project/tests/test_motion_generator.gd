extends TestCase
## MotionGenerator through the real engine: creation, properties, scenes,
## default arguments, signals, bones and model loading failures.

const GRAPH := "res://fixtures/mlp.onnx"
const MODEL_FOLDER := "res://fixtures/model"
const PACKAGE_GRAPHS := ["decoder.onnx", "denoiser.onnx", "encoder.onnx", "text_encoder.onnx"]


func test_instanced_from_gdscript() -> void:
	var generator := MotionGenerator.new()
	check_eq(generator.get_class(), "MotionGenerator", "class")
	check(generator is Node3D, "a MotionGenerator is a Node3D")
	check_eq(generator.model_path, "", "default model_path")
	check_eq(generator.skeleton, NodePath(), "default skeleton")
	check_eq(generator.prompt, "", "default prompt")
	check_eq(generator.playing, false, "default playing")
	check_eq(generator.is_model_loaded(), false, "no model before load_model")
	generator.free()


func test_instanced_from_scene_and_ready_loads_model() -> void:
	var character: Node3D = load("res://scenes/character.tscn").instantiate()
	var generator: MotionGenerator = character.get_node("MotionGenerator")
	check(generator != null, "the scene holds a MotionGenerator")
	check_eq(generator.prompt, "walk forward like an old man", "prompt from .tscn")
	check_eq(generator.skeleton, NodePath("../Skeleton3D"), "skeleton from .tscn")
	check_eq(generator.model_path, MODEL_FOLDER, "model_path from .tscn")
	check_eq(generator.playing, true, "playing from .tscn")
	tree.root.add_child(character)
	await tree.process_frame
	# _ready (a virtual override) loads model_path because playing is on.
	check(generator.is_model_loaded(), "_ready loaded the model: " + generator.get_last_error())
	check_eq(generator.get_loaded_graphs(), PACKAGE_GRAPHS, "graphs of the package")
	check_eq(generator.get_joint_names().size(), 21, "the package's skeleton")
	character.free()


func test_properties_round_trip_and_save_to_tscn() -> void:
	var root := Node3D.new()
	root.name = "Root"
	var skeleton := Skeleton3D.new()
	skeleton.name = "Rig"
	root.add_child(skeleton)
	skeleton.owner = root
	var generator := MotionGenerator.new()
	generator.name = "Generator"
	root.add_child(generator)
	generator.owner = root
	generator.model_path = "res://models/custom"
	generator.skeleton = NodePath("../Rig")
	generator.prompt = "wave with the left hand\nthen run"
	generator.playing = true
	check_eq(generator.model_path, "res://models/custom", "model_path")
	check_eq(generator.skeleton, NodePath("../Rig"), "skeleton")
	check_eq(generator.prompt, "wave with the left hand\nthen run", "prompt")
	check_eq(generator.playing, true, "playing")
	check_eq(generator.get("prompt"), generator.prompt, "get() by name")
	generator.set("playing", false)
	check_eq(generator.is_playing(), false, "set() by name")
	generator.playing = true

	var packed := PackedScene.new()
	check_eq(packed.pack(root), OK, "pack the scene")
	var path := "user://saved_generator.tscn"
	check_eq(ResourceSaver.save(packed, path), OK, "save the scene")
	var text := FileAccess.get_file_as_string(path)
	check(
		text.contains('[node name="Generator" type="MotionGenerator" parent="."'),
		"node saved with its type:\n" + text
	)
	check(text.contains('model_path = "res://models/custom"'), "model_path saved")
	check(text.contains('skeleton = NodePath("../Rig")'), "skeleton saved")
	check(text.contains('prompt = "wave with the left hand\nthen run"'), "prompt saved")
	check(text.contains("playing = true"), "playing saved")

	var loaded: Node3D = (load(path) as PackedScene).instantiate()
	var copy: MotionGenerator = loaded.get_node("Generator")
	check_eq(copy.model_path, "res://models/custom", "model_path loaded back")
	check_eq(copy.skeleton, NodePath("../Rig"), "skeleton loaded back")
	check_eq(copy.prompt, "wave with the left hand\nthen run", "prompt loaded back")
	check_eq(copy.playing, true, "playing loaded back")
	loaded.free()
	root.free()


func test_property_list_has_hints_and_groups() -> void:
	var generator := MotionGenerator.new()
	var found := {}
	var groups: PackedStringArray = []
	for property in generator.get_property_list():
		if property["usage"] & PROPERTY_USAGE_GROUP:
			groups.append(property["name"])
		found[property["name"]] = property
	check_eq(found["model_path"]["hint"], PROPERTY_HINT_DIR, "model_path is a folder")
	check_eq(found["skeleton"]["hint"], PROPERTY_HINT_NODE_PATH_VALID_TYPES, "skeleton hint")
	check_eq(found["skeleton"]["hint_string"], "Skeleton3D", "skeleton accepts Skeleton3D")
	check_eq(found["prompt"]["hint"], PROPERTY_HINT_MULTILINE_TEXT, "prompt is multiline")
	check_eq(found["playing"]["type"], TYPE_BOOL, "playing is a bool")
	for group in ["Model", "Target", "Generation"]:
		check(group in groups, "group " + group)
	generator.free()


func test_default_argument_from_typed_gdscript() -> void:
	var generator: MotionGenerator = MotionGenerator.new()
	generator.model_path = GRAPH
	var loaded: bool = generator.load_model()
	check(
		loaded, "load_model() with the default path loads model_path: " + generator.get_last_error()
	)
	var explicit: bool = generator.load_model(MODEL_FOLDER)
	check(explicit, "load_model(path) with a folder")
	generator.free()


func test_default_argument_from_untyped_gdscript() -> void:
	var generator = MotionGenerator.new()
	generator.model_path = GRAPH
	var loaded = generator.load_model()
	check_eq(loaded, true, "untyped load_model()")
	check_eq(generator.call("load_model"), true, "call('load_model')")
	check_eq(generator.callv("load_model", [GRAPH]), true, "callv with the argument")
	check_eq(generator.get_loaded_graphs(), PackedStringArray(["mlp.onnx"]), "graph name")
	generator.free()


func test_signal_reaches_gdscript() -> void:
	var generator := MotionGenerator.new()
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))
	var loaded_paths: Array[String] = []
	generator.model_loaded.connect(func(path: String) -> void: loaded_paths.append(path))
	generator.load_model("res://fixtures/missing.onnx")
	check_eq(messages.size(), 1, "one generation_failed")
	if messages.size() == 1:
		check(messages[0].contains("missing.onnx"), "the message names the file: " + messages[0])
	generator.load_model(GRAPH)
	check_eq(loaded_paths, [GRAPH] as Array[String], "model_loaded carries the path")
	generator.free()


func test_bone_moved_through_engine_method() -> void:
	var root := Node3D.new()
	var skeleton := Skeleton3D.new()
	skeleton.name = "Skeleton3D"
	skeleton.add_bone("Hips")
	skeleton.add_bone("Spine")
	skeleton.set_bone_parent(1, 0)
	root.add_child(skeleton)
	var generator := MotionGenerator.new()
	root.add_child(generator)
	generator.skeleton = NodePath("../Skeleton3D")
	tree.root.add_child(root)
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))

	var turn := Quaternion(Vector3.UP, 0.7)
	var bend := Quaternion(Vector3.RIGHT, -0.3)
	var applied := generator.apply_joint_rotations({"Hips": turn, &"Spine": bend, "Tail": turn})
	check_eq(applied, 2, "two known bones set")
	check(
		skeleton.get_bone_pose_rotation(0).is_equal_approx(turn),
		"Hips rotated: %s" % skeleton.get_bone_pose_rotation(0)
	)
	check(
		skeleton.get_bone_pose_rotation(1).is_equal_approx(bend),
		"Spine rotated: %s" % skeleton.get_bone_pose_rotation(1)
	)
	check_eq(messages.size(), 1, "the unknown bone is reported")
	if messages.size() == 1:
		check(messages[0].contains("Tail"), "the report names the bone: " + messages[0])
	root.free()


func test_bones_without_skeleton_report_clearly() -> void:
	var generator := MotionGenerator.new()
	tree.root.add_child(generator)
	generator.skeleton = NodePath("../Nothing")
	check_eq(generator.apply_joint_rotations({"Hips": Quaternion()}), 0, "nothing applied")
	check(generator.get_last_error().contains("Skeleton3D"), "error: " + generator.get_last_error())
	generator.free()


func test_shipped_default_model_loads() -> void:
	var generator := MotionGenerator.new()
	var loaded := generator.load_model("res://addons/ardy/models/default")
	check(loaded, "the shipped model loads: " + generator.get_last_error())
	check_eq(generator.get_loaded_graphs(), PackedStringArray(PACKAGE_GRAPHS), "its graphs")
	var joints := generator.get_joint_names()
	check_eq(joints.size(), 21, "21 joints")
	check(joints.has("Hand_L") and joints.has("Toes_R"), "joint names: " + str(joints))
	generator.free()


func test_missing_model_gives_clear_error() -> void:
	var generator := MotionGenerator.new()
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))
	check_eq(generator.load_model("res://fixtures/nowhere/graph.onnx"), false, "missing file")
	check(
		generator.get_last_error().contains("res://fixtures/nowhere/graph.onnx"),
		generator.get_last_error()
	)
	check(
		generator.get_last_error().contains("not found"),
		"says not found: " + generator.get_last_error()
	)
	check_eq(generator.load_model("res://fixtures/no_such_folder"), false, "missing folder")
	check(generator.get_last_error().contains("no_such_folder"), generator.get_last_error())
	check_eq(generator.load_model(""), false, "no path at all")
	check(generator.get_last_error().contains("model_path is empty"), generator.get_last_error())
	check_eq(messages.size(), 3, "one signal per failure")
	check_eq(generator.is_model_loaded(), false, "nothing loaded")
	generator.free()


func test_malformed_model_gives_clear_error_and_keeps_previous() -> void:
	var generator := MotionGenerator.new()
	check(generator.load_model(GRAPH), "a good model first")
	var bad := FileAccess.open("user://malformed.onnx", FileAccess.WRITE)
	bad.store_string("this is not a protobuf graph at all")
	bad.close()
	var empty := FileAccess.open("user://empty.onnx", FileAccess.WRITE)
	empty.close()
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))

	check_eq(generator.load_model("user://malformed.onnx"), false, "malformed graph refused")
	check(
		generator.get_last_error().contains("malformed.onnx"),
		"names the file: " + generator.get_last_error()
	)
	check_eq(generator.load_model("user://empty.onnx"), false, "empty graph refused")
	check(generator.get_last_error().contains("empty"), "says empty: " + generator.get_last_error())
	check_eq(messages.size(), 2, "a signal per failure")
	check(generator.is_model_loaded(), "the previous model stays loaded")
	check_eq(generator.get_loaded_graphs(), PackedStringArray(["mlp.onnx"]), "previous graphs kept")
	check(generator.load_model(GRAPH), "still usable after failures")
	check_eq(generator.get_last_error(), "", "success clears the error")
	generator.free()


func test_model_package_loads_and_is_validated() -> void:
	var generator := MotionGenerator.new()
	check(generator.load_model(MODEL_FOLDER), "the package loads: " + generator.get_last_error())
	check_eq(generator.get_joint_names()[0], "Hips", "first joint")
	check(generator.get_joint_names().has("Hand_R"), "joints by name")
	# A copy of the package with a broken model.json is refused with the field named.
	var broken := "user://broken_package"
	DirAccess.make_dir_recursive_absolute(broken)
	for file in DirAccess.get_files_at(MODEL_FOLDER):
		var bytes := FileAccess.get_file_as_bytes(MODEL_FOLDER.path_join(file))
		var copy := FileAccess.open(broken.path_join(file), FileAccess.WRITE)
		if file == "model.json":
			var text := bytes.get_string_from_utf8().replace('"token_dim": 28', '"token_dim": 30')
			copy.store_string(text)
		else:
			copy.store_buffer(bytes)
		copy.close()
	check_eq(generator.load_model(broken), false, "a wrong token_dim is refused")
	check(generator.get_last_error().contains("tokens.token_dim"), generator.get_last_error())
	check_eq(generator.get_loaded_graphs(), PACKAGE_GRAPHS, "the good package stays loaded")
	# A folder without model.json says so.
	check_eq(generator.load_model("res://scenes"), false, "no package in res://scenes")
	check(generator.get_last_error().contains("model.json"), generator.get_last_error())
	generator.free()
