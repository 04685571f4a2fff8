#pragma once
// The SkeletonModifier3D through which a MotionGenerator writes its pose: it
// runs in the skeleton's update, after AnimationMixer, so `influence` blends
// the generated motion over an AnimationPlayer's and IK or look-at modifiers
// placed after it layer on top. The generator adds it as an internal child
// of the skeleton (never saved with the scene) and removes it again.
#include "godot/class_db.hpp"

namespace ardy {

class MotionPoseModifier : public godot::SkeletonModifier3D {
	GDCLASS(MotionPoseModifier, godot::SkeletonModifier3D)

public:
	void set_generator_id(uint64_t id) { generator_id_ = id; }
	uint64_t get_generator_id() const { return generator_id_; }

	void _process_modification_with_delta(double delta);

protected:
	static void _bind_methods() {}

private:
	uint64_t generator_id_ = 0;
};

} // namespace ardy
