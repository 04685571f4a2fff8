class_name UiStyle
extends RefCounted
## The look the demo's overlay widgets share: dark translucent panels that stay
## readable over the lit 3D scene, one set of colours (a waypoint is the same
## blue on the timeline as its ring on the ground), and a fixed-width font for
## figures that change while they are read.

const MARGIN := 12
const FONT_SIZE := 14
const SMALL_FONT_SIZE := 12
const PANEL := Color(0.06, 0.07, 0.09, 0.8)
const PANEL_BORDER := Color(1, 1, 1, 0.08)
const TEXT := Color(0.93, 0.94, 0.96)
const DIM_TEXT := Color(0.6, 0.64, 0.7)
const WARNING := Color(1.0, 0.55, 0.35)
const ACTIVE_PROMPT := Color(0.3, 0.8, 0.62)
const QUEUED_PROMPT := Color(1.0, 0.74, 0.28)
## The colour of ClickWaypoints' rings.
const WAYPOINT := Color(0.2, 0.6, 1.0)
const KEYFRAME := Color(0.93, 0.42, 0.78)

static var _mono: Font
static var _unchecked: Texture2D


## A rounded dark panel with `padding` pixels inside its edges.
static func panel(padding: int = 10) -> StyleBoxFlat:
	var box := StyleBoxFlat.new()
	box.bg_color = PANEL
	box.border_color = PANEL_BORDER
	box.set_border_width_all(1)
	box.set_corner_radius_all(6)
	box.set_content_margin_all(padding)
	return box


## A monospace system font, or the default font with tabular digits where the
## system has none: either way every digit has one width, so numbers do not
## jitter as they change.
static func mono_font() -> Font:
	if _mono == null:
		var tabular := FontVariation.new()
		tabular.base_font = ThemeDB.fallback_font
		tabular.opentype_features = {
			TextServerManager.get_primary_interface().name_to_tag("tnum"): 1
		}
		var system := SystemFont.new()
		system.font_names = PackedStringArray(
			["DejaVu Sans Mono", "Consolas", "Menlo", "Liberation Mono", "monospace"]
		)
		system.fallbacks = [tabular]
		_mono = system
	return _mono


## A Label in the shared text colour, `size` pixels high.
static func label(text: String, color: Color = TEXT, size: int = FONT_SIZE) -> Label:
	var result := Label.new()
	result.text = text
	result.add_theme_color_override("font_color", color)
	result.add_theme_font_size_override("font_size", size)
	return result


## A slider whose whole track shows over a dark panel: the default theme's
## unfilled part is nearly black.
static func style_slider(slider: Slider) -> void:
	var track := StyleBoxFlat.new()
	track.bg_color = Color(1, 1, 1, 0.16)
	track.set_corner_radius_all(2)
	track.content_margin_top = 2
	track.content_margin_bottom = 2
	var filled := track.duplicate() as StyleBoxFlat
	filled.bg_color = Color(ACTIVE_PROMPT, 0.8)
	slider.add_theme_stylebox_override("slider", track)
	slider.add_theme_stylebox_override("grabber_area", filled)
	slider.add_theme_stylebox_override("grabber_area_highlight", filled)


## A check box whose empty box shows over a dark panel: the default theme's
## unchecked box is nearly black.
static func style_check_box(box: CheckBox) -> void:
	if _unchecked == null:
		var side := box.get_theme_icon("checked").get_width()
		var image := Image.create_empty(side, side, false, Image.FORMAT_RGBA8)
		# An outlined square with cut corners, the size of the checked icon.
		for x in side:
			for y in side:
				var edge := x < 2 or y < 2 or x >= side - 2 or y >= side - 2
				var corner := (x < 2 or x >= side - 2) and (y < 2 or y >= side - 2)
				if edge and not corner:
					image.set_pixel(x, y, Color(DIM_TEXT, 0.9))
				elif not edge:
					image.set_pixel(x, y, Color(0, 0, 0, 0.35))
		_unchecked = ImageTexture.create_from_image(image)
	box.add_theme_icon_override("unchecked", _unchecked)
