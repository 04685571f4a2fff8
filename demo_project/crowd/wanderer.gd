class_name Wanderer
extends DemoCharacter
## One crowd character: a mannequin that walks (in its own style) from one
## random waypoint to the next inside a disc, and now and then waves.

const STYLES := {
	"walk forward": 1.2,
	"walk happily": 1.3,
	"walk like an old man": 0.8,
	"walk sadly": 0.9,
	"walk proudly": 1.2,
	"walk tiredly": 0.9,
	"run": 2.4,
}
const LEAD_SECONDS := 0.6
const WAVE_CHANCE := 0.2
const WAVE_SECONDS := 2.5

## The disc the waypoints are drawn in.
var area_centre := Vector3.ZERO
var area_radius := 12.0
var style := "walk forward"
var _random := RandomNumberGenerator.new()


## `seed_value` makes the walk of this character repeatable.
func setup(seed_value: int) -> void:
	_random.seed = seed_value
	style = STYLES.keys()[_random.randi() % STYLES.size()]


func _ready() -> void:
	generator.seed = _random.randi()
	generator.prompt = style
	generator.waypoint_reached.connect(_on_waypoint_reached)


func _process(_delta: float) -> void:
	# The first waypoint once the clock runs (times count from it).
	if generator.is_generating() and hips != Vector3.INF and generator.get_waypoints().is_empty():
		_next_waypoint(generator.get_time())


func _next_waypoint(start_time: float) -> void:
	generator.clear_waypoints()
	var angle := _random.randf() * TAU
	var distance := sqrt(_random.randf()) * area_radius
	var target := area_centre + Vector3(cos(angle), 0, sin(angle)) * distance
	var speed: float = STYLES[style]
	var seconds := Vector2(target.x - hips.x, target.z - hips.z).length() / speed
	generator.add_waypoint(target, start_time + LEAD_SECONDS + seconds)


func _on_waypoint_reached(_index: int) -> void:
	var now := generator.get_time()
	if _random.randf() < WAVE_CHANCE:
		generator.prompt = "wave with the right hand"
		generator.queue_prompt(style, now + WAVE_SECONDS)
		_next_waypoint(now + WAVE_SECONDS)
	else:
		_next_waypoint(now)
