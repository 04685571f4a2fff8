extends TestCase
## MotionGenerator through the real engine: creation, properties, scenes,
## default arguments, signals and model loading (in the background), with
## its failures.

const MODEL_FOLDER := "res://fixtures/model"
const DEFAULT_MODEL := "res://addons/ardy/models/default"


func test_instanced_from_gdscript() -> void:
	var generator := MotionGenerator.new()
	check_eq(generator.get_class(), "MotionGenerator", "class")
	check(generator is Node3D, "a MotionGenerator is a Node3D")
	check_eq(generator.model_path, DEFAULT_MODEL, "default model_path")
	check_eq(generator.skeleton, NodePath(), "default skeleton")
	check_eq(generator.prompt, "", "default prompt")
	check_eq(generator.playing, false, "default playing")
	check_eq(
		generator.is_model_loaded(), false, "nothing loads before the node is playing in the tree"
	)
	check_eq(generator.get_planned_root(1.0), null, "no planned root before any motion")
	generator.free()


func test_instanced_from_scene_and_ready_loads_model() -> void:
	var character: Node3D = load("res://scenes/character.tscn").instantiate()
	var generator: MotionGenerator = character.get_node("MotionGenerator")
	check(generator != null, "the scene holds a MotionGenerator")
	check_eq(generator.prompt, "walk forward like an old man", "prompt from .tscn")
	check_eq(generator.skeleton, NodePath("../Skeleton3D"), "skeleton from .tscn")
	check_eq(generator.model_path, MODEL_FOLDER, "model_path from .tscn")
	check_eq(generator.playing, true, "playing from .tscn")
	var loaded := [false]
	generator.model_loaded.connect(func() -> void: loaded[0] = true)
	# The scene's skeleton has no bones: said once, by name.
	expect_error("the model's root joint 'Hips' has no bone in the rig")
	tree.root.add_child(character)
	check(not generator.is_model_loaded(), "loading happens in the background, not in _ready")
	check(generator.get_model_sampling().is_empty(), "no model sampling before the model loads")
	# _ready (a virtual override) starts loading model_path because playing is on.
	check(await _wait_for(func() -> bool: return loaded[0]), "model_loaded was emitted")
	check(generator.is_model_loaded(), "the model loaded: " + generator.get_last_error())
	check_eq(generator.get_joint_names().size(), 21, "the package's skeleton")
	var sampling: Dictionary = generator.get_model_sampling()
	check_eq(sampling.get("steps"), 4, "the package's steps")
	check_eq(sampling.get("text_guidance"), 2.0, "the package's w_text")
	check_eq(sampling.get("path_guidance_scale"), 1.0, "the package's path guidance scale")
	check_eq(sampling.size(), 5, "every sampling setting: %s" % sampling)
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
	check_eq(found["bone_map"]["hint_string"], "BoneMap", "bone_map takes a BoneMap")
	check_eq(found["influence"]["hint"], PROPERTY_HINT_RANGE, "influence is a range")
	check_eq(found["target_velocity"]["type"], TYPE_VECTOR3, "target_velocity is a Vector3")
	for group in ["Model", "Target", "Generation", "Sampling", "Streaming", "Editor"]:
		check(group in groups, "group " + group)
	generator.free()


func test_default_arguments_from_typed_and_untyped_gdscript() -> void:
	var generator: MotionGenerator = MotionGenerator.new()
	var untyped = generator
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))
	# heading defaults to NAN (no heading): the call is valid and queued.
	generator.add_waypoint(Vector3(1, 0, 2), 1.0)
	untyped.add_waypoint(Vector3(2, 0, 2), 2.0)
	untyped.call("add_waypoint", Vector3(3, 0, 2), 3.0)
	generator.callv("add_waypoint", [Vector3(4, 0, 2), 4.0, 0.5])
	check_eq(messages.size(), 0, "no failure: " + str(messages))
	# position and rotation default to null: a target with neither is refused by name.
	expect_error("add_joint_target")
	generator.add_joint_target("Hand_R", 1.0)
	check_eq(messages.size(), 1, "one failure")
	check(generator.get_last_error().contains("add_joint_target"), generator.get_last_error())
	generator.free()


func test_bad_inputs_are_reported_once_and_change_nothing() -> void:
	var generator := MotionGenerator.new()
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))
	expect_error("MotionGenerator: ", 16)
	generator.prompt = "walk"
	generator.prompt = "x".repeat(5000)
	check_eq(generator.prompt, "walk", "an over-long prompt leaves the prompt")
	generator.add_waypoint(Vector3(NAN, 0, 1), 1.0)
	generator.add_waypoint(Vector3(INF, 0, 1), 1.0)
	generator.add_waypoint(Vector3(1, 0, 1), -1.0)
	generator.queue_prompt("", 1.0)
	generator.queue_prompt("run", NAN)
	generator.set_path(PackedVector3Array([Vector3.ZERO]), 1.0)
	generator.set_path(PackedVector3Array([Vector3.ZERO, Vector3.ONE]), 0.0)
	generator.set_path(42, 1.0)
	generator.steps = -3
	generator.history_seconds = 100.0
	generator.target_velocity = Vector3(NAN, 0, 0)
	generator.path_guidance_scale = 1.5
	generator.path_guidance_scale = 0.0
	generator.text_only_guidance_scale = 4.5
	generator.text_only_guidance_scale = 0.0
	check_eq(messages.size(), 16, "one message per bad input: " + "\n".join(messages))
	var expected := [
		"prompt",
		"position",
		"position",
		"in the past",
		"queue_prompt",
		"at_seconds",
		"at least 2",
		"speed",
		"Curve3D",
		"steps",
		"history_seconds",
		"target_velocity",
		"path_guidance_scale: 1.5",
		"path_guidance_scale: 0.0",
		"text_only_guidance_scale: 4.5",
		"text_only_guidance_scale: 0.0",
	]
	for i in mini(messages.size(), expected.size()):
		check(
			messages[i].contains(expected[i]),
			"message %d names %s: %s" % [i, expected[i], messages[i]]
		)
	check_eq(generator.steps, 0, "steps unchanged")
	check_eq(generator.history_seconds, 4.0, "history_seconds unchanged")
	check_eq(generator.target_velocity, Vector3.ZERO, "target_velocity unchanged")
	check_eq(generator.path_guidance_scale, -1.0, "path_guidance_scale unchanged")
	check_eq(generator.text_only_guidance_scale, -1.0, "text_only_guidance_scale unchanged")
	generator.free()


func test_missing_model_fails_once_with_the_path() -> void:
	var generator := MotionGenerator.new()
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))
	expect_error("res://fixtures/no_such_folder/model.json': File not found")
	generator.model_path = "res://fixtures/no_such_folder"
	generator.playing = true
	tree.root.add_child(generator)
	check(await _wait_for(func() -> bool: return messages.size() > 0), "generation_failed came")
	for i in 10:
		await tree.process_frame
	check_eq(messages.size(), 1, "reported once, not every frame")
	check(generator.get_last_error().contains("no_such_folder"), generator.get_last_error())
	check(not generator.is_model_loaded(), "nothing loaded")
	generator.free()


func test_bad_model_keeps_the_previous_one() -> void:
	var generator := MotionGenerator.new()
	var messages: Array[String] = []
	generator.generation_failed.connect(func(message: String) -> void: messages.append(message))
	var loads := [0]
	generator.model_loaded.connect(func() -> void: loads[0] += 1)
	generator.model_path = MODEL_FOLDER
	generator.playing = true
	tree.root.add_child(generator)
	check(await _wait_for(func() -> bool: return loads[0] == 1), "the good package loads")
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
	expect_error("tokens.token_dim is 30")
	generator.model_path = broken
	check(await _wait_for(func() -> bool: return messages.size() == 1), "the broken package fails")
	check(generator.get_last_error().contains("tokens.token_dim"), generator.get_last_error())
	check(generator.is_model_loaded(), "the good package stays loaded")
	check_eq(generator.get_joint_names().size(), 21, "and its skeleton")
	# A folder without model.json says so.
	expect_error("res://scenes/model.json")
	generator.model_path = "res://scenes"
	check(
		await _wait_for(func() -> bool: return messages.size() == 2), "no package in res://scenes"
	)
	check(generator.get_last_error().contains("model.json"), generator.get_last_error())
	check(generator.is_model_loaded(), "still the good package")
	generator.free()


func _wait_for(condition: Callable, timeout_seconds := 60.0) -> bool:
	var deadline := Time.get_ticks_msec() + int(timeout_seconds * 1000.0)
	while not condition.call() and Time.get_ticks_msec() < deadline:
		await tree.process_frame
	return condition.call()
