#include "joint_reach.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <glm/geometric.hpp>

#include "kinematics.hpp"

namespace ardy {

JointReach::JointReach(const Skeleton& skeleton) : skeleton_(skeleton), subtrees_(skeleton.joint_count()) {
  // Parents come before their children, so one pass per joint finds the joints below it.
  const size_t joints = skeleton_.joint_count();
  for (size_t joint = 0; joint < joints; ++joint) {
    std::vector<bool> below(joints, false);
    below[joint] = true;
    subtrees_[joint].push_back(joint);
    for (size_t k = joint + 1; k < joints; ++k) {
      const int parent = skeleton_.parent(k);
      if (parent >= 0 && below[static_cast<size_t>(parent)]) {
        below[k] = true;
        subtrees_[joint].push_back(k);
      }
    }
  }
}

void JointReach::follow_below(size_t joint, glm::mat3* global, glm::vec3* position) const {
  for (size_t index = 1; index < subtrees_[joint].size(); ++index) {
    const size_t k = subtrees_[joint][index];
    const auto parent = static_cast<size_t>(skeleton_.parent(k));
    position[k] = position[parent] + global[parent] * skeleton_.offset(k);
  }
}

size_t JointReach::apply(int64_t start_frame, Motion& motion, const std::vector<JointTarget>& targets) const {
  const size_t joints = skeleton_.joint_count();
  size_t changed = 0;
  for (size_t f = 0; f < motion.frame_count; ++f) {
    const int64_t frame = start_frame + static_cast<int64_t>(f);
    glm::mat3* global = motion.global_rotations.data() + f * joints;
    glm::mat3* local = motion.local_rotations.data() + f * joints;
    glm::vec3* position = motion.positions.data() + f * joints;
    bool moved = false;
    for (const JointTarget& target : targets) {
      const int64_t distance = std::llabs(frame - target.frame);
      if (target.joint == 0 || target.joint >= joints || distance > kReachFadeFrames) continue;
      const float a = 1.0f - static_cast<float>(distance) / static_cast<float>(kReachFadeFrames + 1);
      const float weight = a * a * (3.0f - 2.0f * a);
      if (target.position && reach_position(target, weight, global, position)) moved = true;
      if (target.rotation && turn_toward(target, weight, global, position)) moved = true;
    }
    if (moved) {
      for (size_t k = 1; k < joints; ++k) {
        const auto parent = static_cast<size_t>(skeleton_.parent(k));
        local[k] = glm::transpose(global[parent]) * global[k];
      }
      ++changed;
    }
  }
  return changed;
}

bool JointReach::reach_position(const JointTarget& target, float weight, glm::mat3* global,
                                glm::vec3* position) const {
  const int lower = skeleton_.parent(target.joint);
  const int upper = lower > 0 ? skeleton_.parent(static_cast<size_t>(lower)) : -1;
  if (upper <= 0) return false;  // two bones below the root are needed
  const glm::vec3 root = position[0];
  const glm::vec3 wanted = glm::vec3(*target.position) + glm::vec3(root.x, 0.0f, root.z);
  const glm::vec3 end = position[target.joint];
  const glm::vec3 goal = end + (wanted - end) * weight;
  if (glm::length(goal - end) < 1e-4f) return false;
  // A straight limb bends in the plane of itself and the character's
  // forward (a leg about the left-right axis, a T-pose arm about the
  // vertical), or of itself and up when it points forward.
  const auto u = static_cast<size_t>(upper), l = static_cast<size_t>(lower);
  const glm::vec3 facing = global[0] * glm::vec3(0.0f, 0.0f, 1.0f);
  const glm::vec3 forward = heading_rotation(std::atan2(facing.x, facing.z)) * glm::vec3(0.0f, 0.0f, 1.0f);
  const glm::vec3 limb = end - position[u];
  glm::vec3 bend_axis = glm::cross(forward, limb);
  if (glm::length(bend_axis) < 1e-3f * glm::length(limb)) bend_axis = glm::cross(glm::vec3(0.0f, 1.0f, 0.0f), limb);
  bend_axis = glm::length(bend_axis) > 0.0f ? glm::normalize(bend_axis) : glm::vec3(1.0f, 0.0f, 0.0f);
  const TwoBoneRotations turn = two_bone_ik(position[u], position[l], end, goal, bend_axis);
  global[u] = turn.upper * global[u];
  global[l] = turn.lower * global[l];
  // Positions below the upper bone follow before another target reads them.
  follow_below(u, global, position);
  return true;
}

bool JointReach::turn_toward(const JointTarget& target, float weight, glm::mat3* global, glm::vec3* position) const {
  const size_t joint = target.joint;
  const glm::mat3 wanted = slerp_rotation(global[joint], glm::mat3(*target.rotation), weight);
  const glm::mat3 turn = wanted * glm::transpose(global[joint]);
  // Twice the sine of the turn's angle, from its antisymmetric part (exact for small
  // angles, unlike the trace): below about 0.01 deg there is nothing to do.
  const glm::vec3 twice_sine_axis(turn[1][2] - turn[2][1], turn[2][0] - turn[0][2], turn[0][1] - turn[1][0]);
  const bool under_90_deg = turn[0][0] + turn[1][1] + turn[2][2] > 1.0f;
  if (under_90_deg && glm::length(twice_sine_axis) < 3.5e-4f) return false;
  // The joint turns about itself; the joints below it (a foot's toes) turn with it.
  for (const size_t k : subtrees_[joint]) global[k] = turn * global[k];
  follow_below(joint, global, position);
  return true;
}

}  // namespace ardy
