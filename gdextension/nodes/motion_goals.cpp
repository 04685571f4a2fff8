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

double MotionPath::get_duration() const {
	if (!(speed_ > 0.0)) {
		return 0.0;
	}
	double length = 0.0;
	for (int64_t i = 1; i < points_.size(); ++i) {
		const Vector3 from = points_[i - 1];
		const Vector3 to = points_[i];
		length += std::hypot(double(to.x) - double(from.x), double(to.z) - double(from.z));
	}
	return length / speed_;
}

void MotionPrompt::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_time", "seconds"), &MotionPrompt::set_time);
	ClassDB::bind_method(D_METHOD("get_time"), &MotionPrompt::get_time);
	ClassDB::bind_method(D_METHOD("set_text", "text"), &MotionPrompt::set_text);
	ClassDB::bind_method(D_METHOD("get_text"), &MotionPrompt::get_text);
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "time", PROPERTY_HINT_RANGE, "0,3600,0.05,or_greater,suffix:s"), "set_time", "get_time");
	ADD_PROPERTY(PropertyInfo(Variant::STRING, "text", PROPERTY_HINT_MULTILINE_TEXT), "set_text", "get_text");
}

void MotionPath::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_start_time", "seconds"), &MotionPath::set_start_time);
	ClassDB::bind_method(D_METHOD("get_start_time"), &MotionPath::get_start_time);
	ClassDB::bind_method(D_METHOD("set_speed", "metres_per_second"), &MotionPath::set_speed);
	ClassDB::bind_method(D_METHOD("get_speed"), &MotionPath::get_speed);
	ClassDB::bind_method(D_METHOD("set_points", "points"), &MotionPath::set_points);
	ClassDB::bind_method(D_METHOD("get_points"), &MotionPath::get_points);
	ClassDB::bind_method(D_METHOD("get_duration"), &MotionPath::get_duration);
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "start_time", PROPERTY_HINT_RANGE, "0,3600,0.05,or_greater,suffix:s"), "set_start_time", "get_start_time");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "speed", PROPERTY_HINT_RANGE, "0.1,10,0.05,suffix:m/s"), "set_speed", "get_speed");
	ADD_PROPERTY(PropertyInfo(Variant::PACKED_VECTOR3_ARRAY, "points"), "set_points", "get_points");
}

void MotionJointTarget::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_time", "seconds"), &MotionJointTarget::set_time);
	ClassDB::bind_method(D_METHOD("get_time"), &MotionJointTarget::get_time);
	ClassDB::bind_method(D_METHOD("set_bone", "bone"), &MotionJointTarget::set_bone);
	ClassDB::bind_method(D_METHOD("get_bone"), &MotionJointTarget::get_bone);
	ClassDB::bind_method(D_METHOD("set_use_position", "use"), &MotionJointTarget::set_use_position);
	ClassDB::bind_method(D_METHOD("get_use_position"), &MotionJointTarget::get_use_position);
	ClassDB::bind_method(D_METHOD("set_position", "position"), &MotionJointTarget::set_position);
	ClassDB::bind_method(D_METHOD("get_position"), &MotionJointTarget::get_position);
	ClassDB::bind_method(D_METHOD("set_use_rotation", "use"), &MotionJointTarget::set_use_rotation);
	ClassDB::bind_method(D_METHOD("get_use_rotation"), &MotionJointTarget::get_use_rotation);
	ClassDB::bind_method(D_METHOD("set_rotation", "rotation"), &MotionJointTarget::set_rotation);
	ClassDB::bind_method(D_METHOD("get_rotation"), &MotionJointTarget::get_rotation);
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "time", PROPERTY_HINT_RANGE, "0,3600,0.05,or_greater,suffix:s"), "set_time", "get_time");
	ADD_PROPERTY(PropertyInfo(Variant::STRING, "bone"), "set_bone", "get_bone");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "use_position"), "set_use_position", "get_use_position");
	ADD_PROPERTY(PropertyInfo(Variant::VECTOR3, "position", PROPERTY_HINT_NONE, "suffix:m"), "set_position", "get_position");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "use_rotation"), "set_use_rotation", "get_use_rotation");
	ADD_PROPERTY(PropertyInfo(Variant::QUATERNION, "rotation"), "set_rotation", "get_rotation");
}

void MotionContact::_bind_methods() {
	ClassDB::bind_method(D_METHOD("set_start_time", "seconds"), &MotionContact::set_start_time);
	ClassDB::bind_method(D_METHOD("get_start_time"), &MotionContact::get_start_time);
	ClassDB::bind_method(D_METHOD("set_end_time", "seconds"), &MotionContact::set_end_time);
	ClassDB::bind_method(D_METHOD("get_end_time"), &MotionContact::get_end_time);
	ClassDB::bind_method(D_METHOD("set_feet", "feet"), &MotionContact::set_feet);
	ClassDB::bind_method(D_METHOD("get_feet"), &MotionContact::get_feet);
	ClassDB::bind_method(D_METHOD("set_planted", "planted"), &MotionContact::set_planted);
	ClassDB::bind_method(D_METHOD("get_planted"), &MotionContact::get_planted);
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "start_time", PROPERTY_HINT_RANGE, "0,3600,0.05,or_greater,suffix:s"), "set_start_time", "get_start_time");
	ADD_PROPERTY(PropertyInfo(Variant::FLOAT, "end_time", PROPERTY_HINT_RANGE, "0,3600,0.05,or_greater,suffix:s"), "set_end_time", "get_end_time");
	ADD_PROPERTY(PropertyInfo(Variant::INT, "feet", PROPERTY_HINT_ENUM, "Both,Left,Right"), "set_feet", "get_feet");
	ADD_PROPERTY(PropertyInfo(Variant::BOOL, "planted"), "set_planted", "get_planted");
}

} // namespace ardy
