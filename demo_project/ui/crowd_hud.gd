class_name CrowdHud
extends PanelContainer
## The crowd's figures: how many characters generate, the cores generation
## uses (measured CPU time of every generation thread over the last second),
## the playhead time lost to underruns, windows and batches of the shared
## worker, the frame rate and the main-thread cost of all characters.

const REFRESH_SECONDS := 0.5
## The shortest interval the cores figure is measured over: generation threads
## idle between windows, so a refresh soon after another would read a few
## milliseconds of CPU time (often none) as the crowd's load.
const MIN_MEASURE_SECONDS := 0.25

var wanderers: Array[Wanderer] = []
## Cores generation used between the last two refreshes at least
## MIN_MEASURE_SECONDS apart.
var cores := 0.0
var _text: Label
var _last_cpu_seconds := NAN
var _last_wall_seconds := 0.0


func _ready() -> void:
	add_theme_stylebox_override("panel", UiStyle.panel(10))
	_text = UiStyle.label("")
	_text.add_theme_font_override("font", UiStyle.mono_font())
	add_child(_text)
	var timer := Timer.new()
	timer.wait_time = REFRESH_SECONDS
	timer.autostart = true
	timer.timeout.connect(refresh)
	add_child(timer)
	refresh()


## Recomputes the figures now.
func refresh() -> void:
	var totals := figures()
	if totals.generating == 0:
		_text.text = "Crowd of %d: loading the model…" % wanderers.size()
		return
	var wall := Time.get_ticks_usec() / 1e6
	var measured := wall - _last_wall_seconds
	if is_nan(_last_cpu_seconds) or measured >= MIN_MEASURE_SECONDS:
		if not is_nan(_last_cpu_seconds):
			cores = (totals.cpu_seconds - _last_cpu_seconds) / measured
		_last_cpu_seconds = totals.cpu_seconds
		_last_wall_seconds = wall
	_text.text = (
		"\n"
		. join(
			[
				"characters     %3d generating of %d" % [totals.generating, wanderers.size()],
				"inference      %5.2f cores" % cores,
				"underrun       %5.2f %% of played time" % (100.0 * totals.underrun_ratio),
				"windows        %6d (batches up to %d)" % [totals.windows, totals.largest_batch],
				"fps            %4d" % Engine.get_frames_per_second(),
				"main thread    %6.0f µs per frame, all" % totals.main_thread_usec,
			]
		)
	)


## The crowd's summed figures: generating, cpu_seconds, underrun_ratio,
## windows, largest_batch, main_thread_usec.
func figures() -> Dictionary:
	var totals := {
		"generating": 0,
		"cpu_seconds": 0.0,
		"underrun_ratio": 0.0,
		"windows": 0,
		"largest_batch": 0,
		"main_thread_usec": 0.0,
	}
	var played := 0.0
	var underrun := 0.0
	for wanderer in wanderers:
		var generator := wanderer.generator
		if generator == null or not generator.is_generating():
			continue
		var stats := generator.get_stats()
		totals.generating += 1
		totals.cpu_seconds = stats["generation_cpu_seconds"]
		totals.windows += stats["windows"]
		totals.largest_batch = maxi(totals.largest_batch, stats.get("largest_batch", 0))
		totals.main_thread_usec += stats["main_thread_usec"]
		played += generator.get_time()
		underrun += stats["underrun_seconds"]
	totals.underrun_ratio = underrun / played if played > 0.0 else 0.0
	return totals
