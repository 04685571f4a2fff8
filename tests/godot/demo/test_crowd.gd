extends SceneTree
## Runs the demo's crowd scene: all 50 characters generate on the shared
## worker, each walks towards its waypoints, and the HUD's figures are
## measured (generation cores from CPU time, underrun from the planners).
## tests/godot/run.sh runs it in a copy of the demo project; it prints
## "N passed, N failed".

const SECONDS := 10.0

var passed := 0
var failed := 0


func _initialize() -> void:
	_run()


func _run() -> void:
	var crowd: Node3D = load("res://crowd/crowd.tscn").instantiate()
	root.add_child(crowd)
	var wanderers: Array[Wanderer] = crowd.wanderers
	var deadline := Time.get_ticks_msec() + 120000
	await process_frame  # the scene is ready, its characters made
	while (
		wanderers.any(func(one: Wanderer) -> bool: return one.hips == Vector3.INF)
		and Time.get_ticks_msec() < deadline
	):
		await process_frame
	var generating := wanderers.filter(
		func(one: Wanderer) -> bool: return one.generator.is_generating()
	)
	_check(generating.size() == 50, "all 50 characters generate (%d)" % generating.size())
	var starts: Array[Vector3] = []
	for one in wanderers:
		starts.append(one.hips)
	var styles := {}
	for one in wanderers:
		styles[one.style] = true
	_check(styles.size() >= 4, "the crowd walks in several styles (%d)" % styles.size())
	var hud: CrowdHud = crowd.get_node("UI/CrowdHud")
	hud.refresh()
	var clock := wanderers[0].generator
	var until := clock.get_time() + SECONDS
	while clock.get_time() < until and Time.get_ticks_msec() < deadline + 120000:
		await process_frame
	# The HUD's own timer stops so that this refresh measures (the last measure is at
	# least MIN_MEASURE_SECONDS old) and the second one below, at once, does not.
	for child in hud.get_children():
		if child is Timer:
			child.stop()
	await create_timer(CrowdHud.MIN_MEASURE_SECONDS + 0.05).timeout
	hud.refresh()
	var figures := hud.figures()
	var moved := 0
	for i in wanderers.size():
		var now := wanderers[i].hips
		if Vector2(now.x - starts[i].x, now.z - starts[i].z).length() > 2.0:
			moved += 1
	print("  %d of 50 walked over 2 m in %.0f s" % [moved, SECONDS])
	_check(moved >= 45, "the characters wander (%d of 50 walked over 2 m)" % moved)
	var cores: float = hud.cores
	print(
		(
			"  HUD: generation %.2f cores, underrun %.2f %% of played time, %d windows, batches up to %d"
			% [cores, 100.0 * figures.underrun_ratio, figures.windows, figures.largest_batch]
		)
	)
	_check(
		cores > 0.05 and cores <= OS.get_processor_count() + 0.5,
		(
			"the HUD measures the cores generation uses (%.2f of %d)"
			% [cores, OS.get_processor_count()]
		)
	)
	# A refresh right after another (as when the HUD's timer fires in the same frame as
	# an explicit refresh) keeps the figure measured over the longer interval, instead
	# of reading the microseconds between them as the crowd's load.
	hud.refresh()
	_check(
		hud.cores == cores,
		"a second refresh at once keeps the cores figure (%.2f, then %.2f)" % [cores, hud.cores]
	)
	_check(figures.largest_batch > 1, "windows share batches (up to %d)" % figures.largest_batch)
	_check(figures.windows >= 100, "the shared worker made the windows (%d)" % figures.windows)
	crowd.free()
	print("%d passed, %d failed" % [passed, failed])
	quit(failed)


func _check(condition: bool, what: String) -> void:
	if condition:
		passed += 1
		print("PASS crowd: " + what)
	else:
		failed += 1
		printerr("FAIL crowd: " + what)
