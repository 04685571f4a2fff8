#include "motion_timeline.hpp"

using namespace godot;

namespace ardy {

void MotionTimeline::set_length(double seconds) {
	length_ = seconds;
	emit_changed();
}

void MotionTimeline::set_loop(bool loop) {
	loop_ = loop;
	emit_changed();
}

void MotionTimeline::set_prompts(const Array &items) {
	prompts_ = items;
	emit_changed();
}

void MotionTimeline::set_waypoints(const Array &items) {
	waypoints_ = items;
	emit_changed();
}

void MotionTimeline::set_paths(const Array &items) {
	paths_ = items;
	emit_changed();
}

void MotionTimeline::set_keyframes(const Array &items) {
	keyframes_ = items;
	emit_changed();
}

void MotionTimeline::set_joint_targets(const Array &items) {
	joint_targets_ = items;
	emit_changed();
}

void MotionTimeline::set_contacts(const Array &items) {
	contacts_ = items;
	emit_changed();
}

void MotionTimeline::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_length", "seconds"), &MotionTimeline::set_length);
	ClassDB::bind_method(D_METHOD("get_length"), &MotionTimeline::get_length);
	ClassDB::bind_method(D_METHOD("set_loop", "loop"), &MotionTimeline::set_loop);
	ClassDB::bind_method(D_METHOD("get_loop"), &MotionTimeline::get_loop);
	ClassDB::bind_method(D_METHOD("set_prompts", "items"), &MotionTimeline::set_prompts);
	ClassDB::bind_method(D_METHOD("get_prompts"), &MotionTimeline::get_prompts);
	ClassDB::bind_method(D_METHOD("set_waypoints", "items"), &MotionTimeline::set_waypoints);
	ClassDB::bind_method(D_METHOD("get_waypoints"), &MotionTimeline::get_waypoints);
	ClassDB::bind_method(D_METHOD("set_paths", "items"), &MotionTimeline::set_paths);
	ClassDB::bind_method(D_METHOD("get_paths"), &MotionTimeline::get_paths);
	ClassDB::bind_method(D_METHOD("set_keyframes", "items"), &MotionTimeline::set_keyframes);
	ClassDB::bind_method(D_METHOD("get_keyframes"), &MotionTimeline::get_keyframes);
	ClassDB::bind_method(D_METHOD("set_joint_targets", "items"), &MotionTimeline::set_joint_targets);
	ClassDB::bind_method(D_METHOD("get_joint_targets"), &MotionTimeline::get_joint_targets);
	ClassDB::bind_method(D_METHOD("set_contacts", "items"), &MotionTimeline::set_contacts);
	ClassDB::bind_method(D_METHOD("get_contacts"), &MotionTimeline::get_contacts);
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "length", PROPERTY_HINT_RANGE, "0.1,3600,0.1,or_greater,suffix:s"), "set_length", "get_length");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "loop"), "set_loop", "get_loop");
	ADD_GROUP("Tracks", "");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "prompts", PROPERTY_HINT_TYPE_STRING, "24/17:MotionPrompt"), "set_prompts", "get_prompts");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "waypoints", PROPERTY_HINT_TYPE_STRING, "24/17:MotionWaypoint"), "set_waypoints", "get_waypoints");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "paths", PROPERTY_HINT_TYPE_STRING, "24/17:MotionPath"), "set_paths", "get_paths");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "keyframes", PROPERTY_HINT_TYPE_STRING, "24/17:MotionKeyframe"), "set_keyframes", "get_keyframes");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "joint_targets", PROPERTY_HINT_TYPE_STRING, "24/17:MotionJointTarget"), "set_joint_targets",
			"get_joint_targets");
	ADD_PROPERTY(PropertyInfo(Variant::ARRAY, "contacts", PROPERTY_HINT_TYPE_STRING, "24/17:MotionContact"), "set_contacts", "get_contacts");
}

} // namespace ardy
