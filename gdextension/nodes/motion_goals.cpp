#include "motion_goals.hpp"

using namespace godot;

namespace ardy {

void MotionWaypoint::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_position", "position"), &MotionWaypoint::set_position);
	ClassDB::bind_method(D_METHOD("get_position"), &MotionWaypoint::get_position);
	ClassDB::bind_method(D_METHOD("set_time", "seconds"), &MotionWaypoint::set_time);
	ClassDB::bind_method(D_METHOD("get_time"), &MotionWaypoint::get_time);
	ClassDB::bind_method(D_METHOD("set_use_heading", "use"), &MotionWaypoint::set_use_heading);
	ClassDB::bind_method(D_METHOD("get_use_heading"), &MotionWaypoint::get_use_heading);
	ClassDB::bind_method(D_METHOD("set_heading", "radians"), &MotionWaypoint::set_heading);
	ClassDB::bind_method(D_METHOD("get_heading"), &MotionWaypoint::get_heading);
	ADD_PROPERTY(PropertyInfo(Variant::VECTOR3, "position", PROPERTY_HINT_NONE, "suffix:m"), "set_position", "get_position");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "time", PROPERTY_HINT_RANGE, "0,3600,0.05,or_greater,suffix:s"), "set_time", "get_time");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "use_heading"), "set_use_heading", "get_use_heading");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "heading", PROPERTY_HINT_RANGE, "-180,180,0.1,radians_as_degrees"), "set_heading", "get_heading");
}

void MotionKeyframe::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_time", "seconds"), &MotionKeyframe::set_time);
	ClassDB::bind_method(D_METHOD("get_time"), &MotionKeyframe::get_time);
	ClassDB::bind_method(D_METHOD("set_pose", "pose"), &MotionKeyframe::set_pose);
	ClassDB::bind_method(D_METHOD("get_pose"), &MotionKeyframe::get_pose);
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "time", PROPERTY_HINT_RANGE, "0,3600,0.05,or_greater,suffix:s"), "set_time", "get_time");
	ADD_PROPERTY(PropertyInfo(Variant::DICTIONARY, "pose"), "set_pose", "get_pose");
}

} // namespace ardy
