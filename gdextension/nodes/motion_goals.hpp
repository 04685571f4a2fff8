#pragma once
// The goals a designer places without code: small resources saved with the
// scene in MotionGenerator.waypoints and MotionGenerator.keyframes
// (add_waypoint and add_pose_keyframe append to the same lists), and the
// items of a MotionTimeline's tracks. Every setter emits `changed`, so the
// editor's timeline and gizmos redraw.
#include "godot/class_db.hpp"

#include <cmath>

namespace ardy {

// A root waypoint: where the character's hips are (on the ground plane) at
// a time of the motion clock, optionally facing a heading.
class MotionWaypoint : public godot::Resource {
	GDCLASS(MotionWaypoint, godot::Resource)

public:
	void set_position(const godot::Vector3 &position) {
		position_ = position;
		emit_changed();
	}
	godot::Vector3 get_position() const { return position_; }
	void set_time(double seconds) {
		time_ = seconds;
		emit_changed();
	}
	double get_time() const { return time_; }
	void set_use_heading(bool use) {
		use_heading_ = use;
		emit_changed();
	}
	bool get_use_heading() const { return use_heading_; }
	void set_heading(double radians) {
		heading_ = radians;
		emit_changed();
	}
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
	void set_time(double seconds) {
		time_ = seconds;
		emit_changed();
	}
	double get_time() const { return time_; }
	void set_pose(const godot::Dictionary &pose) {
		pose_ = pose;
		emit_changed();
	}
	godot::Dictionary get_pose() const { return pose_; }

protected:
	static void _bind_methods();

private:
	double time_ = 0.0;
	godot::Dictionary pose_;
};

// A prompt of a timeline: `text` from `time` on, until the next prompt
// (empty text: no prompt from then on).
class MotionPrompt : public godot::Resource {
	GDCLASS(MotionPrompt, godot::Resource)

public:
	void set_time(double seconds) {
		time_ = seconds;
		emit_changed();
	}
	double get_time() const { return time_; }
	void set_text(const godot::String &text) {
		text_ = text;
		emit_changed();
	}
	godot::String get_text() const { return text_; }

protected:
	static void _bind_methods();

private:
	double time_ = 0.0;
	godot::String text_;
};

// A root path of a timeline: the character walks the polyline `points`
// (world space; heights ignored) at `speed` from `start_time`, facing along it.
class MotionPath : public godot::Resource {
	GDCLASS(MotionPath, godot::Resource)

public:
	void set_start_time(double seconds) {
		start_time_ = seconds;
		emit_changed();
	}
	double get_start_time() const { return start_time_; }
	void set_speed(double metres_per_second) {
		speed_ = metres_per_second;
		emit_changed();
	}
	double get_speed() const { return speed_; }
	void set_points(const godot::PackedVector3Array &points) {
		points_ = points;
		emit_changed();
	}
	godot::PackedVector3Array get_points() const { return points_; }
	// Seconds the path takes: its length on the ground over the speed.
	double get_duration() const;

protected:
	static void _bind_methods();

private:
	double start_time_ = 0.0;
	double speed_ = 1.2;
	godot::PackedVector3Array points_;
};

// A joint target of a timeline: where a bone is (world position) and/or how
// it is turned (world rotation) at a time.
class MotionJointTarget : public godot::Resource {
	GDCLASS(MotionJointTarget, godot::Resource)

public:
	void set_time(double seconds) {
		time_ = seconds;
		emit_changed();
	}
	double get_time() const { return time_; }
	void set_bone(const godot::String &bone) {
		bone_ = bone;
		emit_changed();
	}
	godot::String get_bone() const { return bone_; }
	void set_use_position(bool use) {
		use_position_ = use;
		emit_changed();
	}
	bool get_use_position() const { return use_position_; }
	void set_position(const godot::Vector3 &position) {
		position_ = position;
		emit_changed();
	}
	godot::Vector3 get_position() const { return position_; }
	void set_use_rotation(bool use) {
		use_rotation_ = use;
		emit_changed();
	}
	bool get_use_rotation() const { return use_rotation_; }
	void set_rotation(const godot::Quaternion &rotation) {
		rotation_ = rotation;
		emit_changed();
	}
	godot::Quaternion get_rotation() const { return rotation_; }

protected:
	static void _bind_methods();

private:
	double time_ = 0.0;
	godot::String bone_ = "RightHand";
	bool use_position_ = true;
	godot::Vector3 position_;
	bool use_rotation_ = false;
	godot::Quaternion rotation_;
};

// Foot contacts of a timeline: the feet stay planted (or lifted) over
// [start_time, end_time).
class MotionContact : public godot::Resource {
	GDCLASS(MotionContact, godot::Resource)

public:
	enum Feet {
		FEET_BOTH = 0,
		FEET_LEFT = 1,
		FEET_RIGHT = 2,
	};
	void set_start_time(double seconds) {
		start_time_ = seconds;
		emit_changed();
	}
	double get_start_time() const { return start_time_; }
	void set_end_time(double seconds) {
		end_time_ = seconds;
		emit_changed();
	}
	double get_end_time() const { return end_time_; }
	void set_feet(int64_t feet) {
		feet_ = feet;
		emit_changed();
	}
	int64_t get_feet() const { return feet_; }
	void set_planted(bool planted) {
		planted_ = planted;
		emit_changed();
	}
	bool get_planted() const { return planted_; }

protected:
	static void _bind_methods();

private:
	double start_time_ = 0.0;
	double end_time_ = 1.0;
	int64_t feet_ = FEET_BOTH;
	bool planted_ = true;
};

} // namespace ardy
