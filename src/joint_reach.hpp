#pragma once

// Joint targets reached on the frames the runtime shows (like the foot lock
// and the output filter, never on what the model reads back as history). The
// model alone misses end-effector targets (docs/evaluation: about 0.1 m and
// 25 deg): near a target's frame
// - a position target turns the two bones above the joint (for a hand: upper
//   and lower arm) by two-bone IK so that the joint is at the target; the
//   joint keeps its world rotation;
// - a rotation target turns the joint about itself toward the target's world
//   rotation (slerp); the joints below it (a foot's toes) turn with it;
// both blending in and out over kReachFadeFrames on either side (smoothstep).
// Targets of the root, and position targets of a joint without two bones
// between it and the root, are left to the model.

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
  // toward the targets within kReachFadeFrames of those frames. A
  // target's position follows JointTarget's convention (relative to the
  // root's ground point), taken from the root of each frame it bends.
  // Returns the number of frames changed.
  size_t apply(int64_t start_frame, Motion& motion, const std::vector<JointTarget>& targets) const;

 private:
  // One frame's world rotations and positions, moved toward one target with
  // blend `weight` (0..1); false when nothing moved.
  bool reach_position(const JointTarget& target, float weight, glm::mat3* global, glm::vec3* position) const;
  bool turn_toward(const JointTarget& target, float weight, glm::mat3* global, glm::vec3* position) const;
  // Positions of the joints below `joint` from their parents' (already moved) rotations.
  void follow_below(size_t joint, glm::mat3* global, glm::vec3* position) const;

  const Skeleton& skeleton_;
  std::vector<std::vector<size_t>> subtrees_;  // per joint: itself, then the joints below it
};

}  // namespace ardy
