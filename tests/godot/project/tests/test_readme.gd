extends TestCase
## The README's "Using the node" snippet, run as it is written: attached to a
## character whose rig is its child Skeleton3D, it makes the character walk,
## change prompt and reach the waypoint.


func _snippet() -> String:
	var readme := FileAccess.get_file_as_string("res://fixtures/README.md")
	var section := readme.get_slice("## Using the node", 1)
	return section.get_slice("```gdscript\n", 1).get_slice("```", 0)


func test_readme_snippet_runs_and_the_character_moves() -> void:
	var source := _snippet()
	check(source.contains("MotionGenerator.new()"), "the README has the snippet:\n" + source)
	var script := GDScript.new()
	script.source_code = source
	check_eq(script.reload(), OK, "the snippet compiles")
	var character := Node3D.new()
	var rig := TestRigs.model_rig(TestCharacter.MODEL)
	character.add_child(rig)
	character.set_script(script)
	var positions: Array[Vector3] = []
	rig.skeleton_updated.connect(
		func() -> void: positions.append(rig.global_transform * rig.get_bone_global_pose(0).origin)
	)
	tree.root.add_child(character)
	var generator: MotionGenerator = null
	for child in character.get_children():
		if child is MotionGenerator:
			generator = child
	check(generator != null, "the snippet added a MotionGenerator")
	if generator == null:
		character.free()
		return
	var started: Array[String] = []
	generator.prompt_started.connect(func(text: String) -> void: started.append(text))
	var deadline := Time.get_ticks_msec() + 90000
	while generator.get_time() < 6.5 and Time.get_ticks_msec() < deadline:
		await tree.process_frame
	check(generator.get_time() >= 6.5, "6.5 s of motion played")
	check(positions.size() > 1, "the rig was posed")
	if positions.size() > 1:
		var closest := INF
		for position in positions:
			closest = minf(closest, Vector2(position.x - 2, position.z - 4).length())
		print("  README snippet: prompts %s, closest to the waypoint %.2f m" % [started, closest])
		check(closest < 0.3, "the hips passed %.2f m from the snippet's waypoint" % closest)
	check(started.has("wave with the left hand"), "the queued prompt started: %s" % [started])
	character.free()
