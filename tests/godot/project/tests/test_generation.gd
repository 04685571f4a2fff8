extends TestCase
## MotionGenerator generating motion in the real engine with the shipped
## model, through the public API only: prompts, waypoints, paths, keyboard
## velocity, keyframes, joint targets, root motion and retargeting. Times are
## the node's motion clock; each test plays a few seconds in real time.


func _start(prompt: String, rig: Skeleton3D = null) -> TestCharacter:
	var character := TestCharacter.new(rig, tree.root)
	character.generator.prompt = prompt
	character.generator.playing = true
	check(
		await character.wait_until_generating(tree),
		"generation started: " + character.generator.get_last_error()
	)
	return character


func _ground_distance(a: Vector3, b: Vector3) -> float:
	return Vector2(a.x - b.x, a.z - b.z).length()


func test_walk_moves_the_hips_and_wave_keeps_them() -> void:
	var character := await _start("walk forward")
	var generator := character.generator
	var started := {}
	generator.prompt_started.connect(func(text: String) -> void: started[text] = generator.get_time())
	check(await character.wait_until_time(tree, 3.0), "the motion clock reached 3 s")
	var travel := _ground_distance(character.position_at("Hips", 0.05), character.position_at("Hips", 3.0))
	print("  walk: hips travelled %.2f m in 3 s" % travel)
	check(travel > 1.5, "walking moved the hips %.2f m in 3 s, expected more than 1.5 m" % travel)

	var changed_at := generator.get_time()
	generator.prompt = "wave with the right hand"
	check(await character.wait_until_time(tree, changed_at + 5.0), "5 s more of waving")
	var response: float = started.get("wave with the right hand", INF) - changed_at
	print("  wave: the prompt reached the motion after %.2f s" % response)
	check(response <= 1.0, "the new prompt reached the motion after %.2f s, expected at most 1 s" % response)
	var hand_above := 0
	var counted := 0
	for sample in character.samples:
		if sample["time"] < changed_at + 1.5:
			continue
		counted += 1
		if sample["bones"]["Hand_R"].y > sample["bones"]["UpperArm_R"].y:
			hand_above += 1
	var settled := character.position_at("Hips", changed_at + 2.0)
	var drift := _ground_distance(settled, character.last_position("Hips"))
	print("  wave: right hand above the shoulder in %d of %d frames, hips moved %.2f m" % [hand_above, counted, drift])
	check(hand_above > 0, "the right hand rose above the shoulder while waving")
	check(drift < 0.5, "the hips moved %.2f m while waving, expected less than 0.5 m" % drift)
	character.dispose()


func test_waypoint_is_reached_and_signalled() -> void:
	var character := await _start("walk")
	var generator := character.generator
	var reached: Array[int] = []
	generator.waypoint_reached.connect(func(index: int) -> void: reached.append(index))
	await character.wait_until_time(tree, 0.2)
	var target := character.last_position("Hips") + Vector3(5.0, 0.0, 0.0)
	target.y = 0.0
	generator.add_waypoint(target, 4.0)
	check(await character.wait_until_time(tree, 5.0), "the clock reached 5 s")
	var closest := INF
	for sample in character.samples:
		closest = minf(closest, _ground_distance(sample["bones"]["Hips"], target))
	print("  waypoint 5 m away at 4 s: closest approach %.2f m" % closest)
	check(closest < 0.3, "the hips passed %.2f m from the waypoint, expected under 0.3 m" % closest)
	check_eq(reached, [0] as Array[int], "waypoint_reached fired once for waypoint 0")
	character.dispose()


func test_curve_path_is_followed() -> void:
	var character := await _start("walk")
	var generator := character.generator
	await character.wait_until_time(tree, 0.2)
	var start := character.last_position("Hips")
	start.y = 0.0
	var curve := Curve3D.new()
	curve.add_point(start)
	curve.add_point(start + Vector3(2, 0, 2), Vector3(-1, 0, 0), Vector3(1, 0, 0))
	curve.add_point(start + Vector3(4, 0, 0))
	generator.set_path(curve, 1.2)
	var begun := generator.get_time()
	var seconds := curve.get_baked_length() / 1.2
	check(await character.wait_until_time(tree, begun + seconds), "the path's duration played")
	var total := 0.0
	var count := 0
	for sample in character.samples:
		if sample["time"] < begun + 0.5:
			continue
		var hips: Vector3 = sample["bones"]["Hips"]
		var on_curve := curve.get_closest_point(Vector3(hips.x, 0, hips.z))
		total += _ground_distance(hips, on_curve)
		count += 1
	var mean := total / maxi(count, 1)
	print("  path of %.1f m: mean distance from the curve %.3f m over %d frames" % [curve.get_baked_length(), mean, count])
	check(count > 0 and mean < 0.25, "mean path error %.3f m, expected under 0.25 m" % mean)
	character.dispose()


## Mean ground velocity of the hips between two motion times.
func _velocity(character: TestCharacter, from: float, to: float) -> Vector3:
	var a := character.position_at("Hips", from)
	var b := character.position_at("Hips", to)
	return Vector3(b.x - a.x, 0, b.z - a.z) / (to - from)


func test_target_velocity_steers_turns_and_runs() -> void:
	var character := await _start("walk")
	var generator := character.generator
	await character.wait_until_time(tree, 0.5)
	generator.target_velocity = Vector3(-1.2, 0, 0)
	var set_at := generator.get_time()
	check(await character.wait_until_time(tree, set_at + 3.0), "3 s of steering")
	var walk := _velocity(character, set_at + 2.0, set_at + 3.0)
	print("  target 1.2 m/s along -X: %.2f m/s, direction %s" % [walk.length(), walk.normalized()])
	check(absf(walk.length() - 1.2) <= 0.36, "speed %.2f m/s, expected 1.2 +- 30 %%" % walk.length())
	check(walk.normalized().dot(Vector3(-1, 0, 0)) > 0.9, "moving along -X: %s" % walk)

	# A 90 degree turn: the hips' direction of travel follows within 0.8 s.
	generator.target_velocity = Vector3(0, 0, 1.2)
	var turned_at := generator.get_time()
	check(await character.wait_until_time(tree, turned_at + 1.2), "1.2 s after the turn")
	var turn_time := INF
	var t := turned_at + 0.1
	while t <= turned_at + 1.2:
		var direction := _velocity(character, t - 0.1, t)
		if direction.length() > 0.2 and rad_to_deg(direction.angle_to(Vector3(0, 0, 1))) < 30.0:
			turn_time = t - turned_at
			break
		t += 0.05
	print("  turn by 90 degrees: heading within 30 degrees after %.2f s" % turn_time)
	check(turn_time <= 0.8, "turned within 30 degrees after %.2f s, expected at most 0.8 s" % turn_time)

	generator.prompt = "run"
	generator.target_velocity = Vector3(0, 0, 2.5)
	var run_at := generator.get_time()
	check(await character.wait_until_time(tree, run_at + 3.0), "3 s of running")
	var run := _velocity(character, run_at + 2.0, run_at + 3.0)
	print("  run at 2.5 m/s: %.2f m/s" % run.length())
	check(absf(run.length() - 2.5) <= 0.625, "running at %.2f m/s, expected 2.5 +- 25 %%" % run.length())
	character.dispose()
