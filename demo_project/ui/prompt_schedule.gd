class_name PromptSchedule
extends RefCounted
## The prompts a PromptTimeline shows, as {"text": String, "time": float} on
## the motion clock: those that started (the last one is playing) and those
## queued that have not started yet. MotionGenerator has no getter for its
## queued prompts, so the timeline keeps this list of what it queued itself.

enum State { PLAYED, PLAYING, QUEUED }

## Started prompts, oldest first; the last one is playing.
var played: Array[Dictionary] = []
## Queued prompts that have not started, soonest first.
var queued: Array[Dictionary] = []


func add_queued(text: String, time: float) -> void:
	var index := 0
	while index < queued.size() and queued[index]["time"] <= time:
		index += 1
	queued.insert(index, {"text": text, "time": time})


## `text` started playing at `time` (prompt_started): the first queued entry
## with that text is no longer waiting.
func start(text: String, time: float) -> void:
	played.append({"text": text, "time": time})
	for i in queued.size():
		if _same(queued[i]["text"], text):
			queued.remove_at(i)
			return


func playing() -> String:
	return played[-1]["text"] if not played.is_empty() else ""


## Forgets what ended before `since`, and queued prompts that are due with
## their text already playing: the node fires prompt_started only for a change
## of text, so those never start.
func prune(now: float, since: float) -> void:
	while played.size() > 1 and played[1]["time"] < since:
		played.remove_at(0)
	var current := playing()
	queued = queued.filter(
		func(entry: Dictionary) -> bool:
			var due: bool = entry["time"] <= now
			return entry["time"] >= since and not (due and _same(entry["text"], current))
	)


func clear() -> void:
	played.clear()
	queued.clear()


## Every prompt as {"text", "time", "state": State}, by time: each holds until
## the next one's time.
func spans() -> Array[Dictionary]:
	var result: Array[Dictionary] = []
	for i in played.size():
		var state := State.PLAYING if i == played.size() - 1 else State.PLAYED
		result.append({"text": played[i]["text"], "time": played[i]["time"], "state": state})
	for entry in queued:
		result.append({"text": entry["text"], "time": entry["time"], "state": State.QUEUED})
	result.sort_custom(func(a: Dictionary, b: Dictionary) -> bool: return a["time"] < b["time"])
	return result


# The node may hand a prompt back normalised (case, spaces).
func _same(a: String, b: String) -> bool:
	return a.strip_edges().to_lower() == b.strip_edges().to_lower()
