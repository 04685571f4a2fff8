#include "motion_pose_modifier.hpp"

#include "motion_generator.hpp"

using namespace godot;

namespace ardy {

void MotionPoseModifier::_process_modification_with_delta(double) {
	auto *generator = Object::cast_to<MotionGenerator>(object_from_instance_id(generator_id_));
	if (generator == nullptr) {
		// Its generator is gone (or let it go): nothing to write, ever again.
		generator_id_ = 0;
		queue_free();
		return;
	}
	generator->write_pose(get_skeleton());
}

} // namespace ardy
