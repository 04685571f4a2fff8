#pragma once
// The goals a designer places in the inspector without code: small
// resources saved with the scene in MotionGenerator.waypoints and
// MotionGenerator.keyframes (add_waypoint and add_pose_keyframe append to
// the same lists).
#include "godot/class_db.hpp"

#include <cmath>

namespace ardy {

// A root waypoint: where the character's hips are (on the ground plane) at
// a time of the motion clock, optionally facing a heading.
class MotionWaypoint : public godot::Resource {
	GDCLASS(MotionWaypoint, godot::Resource)

public:
	void set_position(const godot::Vector3 &position) { position_ = position; }
	godot::Vector3 get_position() const { return position_; }
	void set_time(double seconds) { time_ = seconds; }
	double get_time() const { return time_; }
	void set_use_heading(bool use) { use_heading_ = use; }
	bool get_use_heading() const { return use_heading_; }
	void set_heading(double radians) { heading_ = radians; }
	double get_heading() const { return heading_; }

protected:
	static void _bind_methods();

private:
	godot::Vector3 position_;
	double time_ = 0.0;
	bool use_heading_ = false;
	double heading_ = 0.0;
};

// A full-body pose keyframe: local pose rotations of the rig's bones
// (bone name -> Quaternion; bones left out keep their rest) at a time.
class MotionKeyframe : public godot::Resource {
	GDCLASS(MotionKeyframe, godot::Resource)

public:
	void set_time(double seconds) { time_ = seconds; }
	double get_time() const { return time_; }
	void set_pose(const godot::Dictionary &pose) { pose_ = pose; }
	godot::Dictionary get_pose() const { return pose_; }

protected:
	static void _bind_methods();

private:
	double time_ = 0.0;
	godot::Dictionary pose_;
};

} // namespace ardy
