#pragma once
// MotionTimeline: an authored sequence saved as a resource (.tres): tracks of
// prompts, waypoints, paths, pose keyframes, joint targets and foot contacts,
// each item with its times on the motion clock. MotionGenerator.timeline
// plays it (once or looping), bakes it (bake_animation) and converts it to
// and from the JSON timeline of ardy-generate (timeline_to_json,
// timeline_from_json): one schema, src/timeline.hpp's.
#include "godot/class_db.hpp"

namespace ardy {

class MotionTimeline : public godot::Resource {
	GDCLASS(MotionTimeline, godot::Resource)

public:
	void set_length(double seconds);
	double get_length() const { return length_; }
	void set_loop(bool loop);
	bool get_loop() const { return loop_; }
	void set_prompts(const godot::Array &items);
	godot::Array get_prompts() const { return prompts_; }
	void set_waypoints(const godot::Array &items);
	godot::Array get_waypoints() const { return waypoints_; }
	void set_paths(const godot::Array &items);
	godot::Array get_paths() const { return paths_; }
	void set_keyframes(const godot::Array &items);
	godot::Array get_keyframes() const { return keyframes_; }
	void set_joint_targets(const godot::Array &items);
	godot::Array get_joint_targets() const { return joint_targets_; }
	void set_contacts(const godot::Array &items);
	godot::Array get_contacts() const { return contacts_; }

protected:
	static void _bind_methods();

private:
	double length_ = 10.0;
	bool loop_ = false;
	godot::Array prompts_;
	godot::Array waypoints_;
	godot::Array paths_;
	godot::Array keyframes_;
	godot::Array joint_targets_;
	godot::Array contacts_;
};

} // namespace ardy
