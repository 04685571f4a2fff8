extends Node3D
## The crowd scene: 50 mannequins wander between random waypoints, each in its
## own walking style, all generated on the shared inference worker. The HUD
## shows the cores generation uses and the playhead time lost to underruns.

const COUNT := 50
const AREA_RADIUS := 12.0
const SPACING := 1.6
const MAIN_SCENE := "res://main.tscn"

var wanderers: Array[Wanderer] = []

@onready var people: Node3D = $People
@onready var camera: OrbitCamera = $Camera
@onready var hud: CrowdHud = $UI/CrowdHud
@onready var back: Button = $UI/Back


func _ready() -> void:
	# Start on a grid so no two characters begin inside each other.
	var columns := ceili(sqrt(COUNT))
	for i in COUNT:
		var wanderer := Wanderer.new()
		wanderer.name = "Wanderer%02d" % i
		wanderer.setup(1000 + i)
		wanderer.area_radius = AREA_RADIUS
		var cell := Vector2(i % columns, i / columns) - Vector2.ONE * (columns - 1) * 0.5
		wanderer.position = Vector3(cell.x, 0, cell.y) * SPACING
		wanderer.rotation.y = TAU * i / COUNT
		people.add_child(wanderer)
		wanderers.append(wanderer)
	hud.wanderers = wanderers
	camera.follow = func() -> Vector3: return Vector3.ZERO
	back.pressed.connect(func() -> void: get_tree().change_scene_to_file(MAIN_SCENE))
