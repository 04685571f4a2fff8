#pragma once

// Joint position targets reached on the frames the runtime shows (like the
// foot lock and the output filter, never on what the model reads back as
// history). The model alone misses end-effector targets (docs/evaluation:
// 0.107 m on average, more for a hand while another prompt plays): near a
// target's frame the two bones above the joint (for a hand: upper and lower
// arm) are turned by two-bone IK so that the joint is at the target at that
// frame, blending in and out over kReachFadeFrames on either side
// (smoothstep); the joint keeps its world rotation, so a hand's fingers
// follow it. Targets of the root, or of a joint without two bones between it
// and the root, are left to the model.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "constraints.hpp"
#include "sampler.hpp"
#include "skeleton.hpp"

namespace ardy {

// Frames on either side of a target's frame over which the reach blends in and out.
constexpr int64_t kReachFadeFrames = 10;

class JointReach {
 public:
  explicit JointReach(const Skeleton& skeleton);

  // Bends `motion` (model frames start_frame .. start_frame + frame_count - 1)
  // toward the position targets within kReachFadeFrames of those frames. A
  // target's position follows JointTarget's convention (relative to the
  // root's ground point), taken from the root of each frame it bends.
  // Returns the number of frames changed.
  size_t apply(int64_t start_frame, Motion& motion, const std::vector<JointTarget>& targets) const;

 private:
  const Skeleton& skeleton_;
};

}  // namespace ardy
