// joint_reach: a hand target reached exactly at its frame by two-bone IK,
// blended in and out around it, bones kept at their lengths.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

#include "joint_reach.hpp"
#include "kinematics.hpp"
#include "support/skeletons.hpp"

namespace {

// `frames` frames of the rest pose with the hips at (x, 0.9, z).
ardy::Motion rest_motion(const ardy::Skeleton& skeleton, size_t frames, float x, float z) {
  ardy::Motion motion;
  motion.frame_count = frames;
  motion.joint_count = skeleton.joint_count();
  const std::vector<glm::mat3> local(skeleton.joint_count(), glm::mat3(1.0f));
  const ardy::GlobalPose pose = ardy::forward_kinematics(skeleton, glm::vec3(x, 0.9f, z), local);
  for (size_t f = 0; f < frames; ++f) {
    motion.local_rotations.insert(motion.local_rotations.end(), local.begin(), local.end());
    motion.global_rotations.insert(motion.global_rotations.end(), pose.rotations.begin(), pose.rotations.end());
    motion.positions.insert(motion.positions.end(), pose.positions.begin(), pose.positions.end());
  }
  return motion;
}

}  // namespace

TEST_CASE("a hand target is reached at its frame and blends in and out") {
  const ardy::Skeleton skeleton = ardy_test::ardy_test_skeleton();
  const size_t hand = *skeleton.find("Hand_R"), lower = *skeleton.find("LowerArm_R"), upper = *skeleton.find("UpperArm_R");
  const size_t joints = skeleton.joint_count();
  ardy::Motion motion = rest_motion(skeleton, 40, 2.0f, -1.0f);
  const ardy::Motion before = motion;
  // 0.3 m in front of the right shoulder, 0.1 m down: within the arm's reach.
  const glm::vec3 shoulder = before.positions[upper];
  ardy::JointTarget target;
  target.frame = 120;  // the motion starts at model frame 100
  target.joint = hand;
  target.position = glm::dvec3(shoulder - glm::vec3(2.0f, 0.0f, -1.0f) + glm::vec3(0.0f, -0.1f, 0.3f));
  const size_t changed = ardy::JointReach(skeleton).apply(100, motion, {target});
  CHECK(changed == static_cast<size_t>(2 * ardy::kReachFadeFrames + 1));

  const glm::vec3 wanted = glm::vec3(*target.position) + glm::vec3(2.0f, 0.0f, -1.0f);
  CHECK(glm::length(motion.positions[20 * joints + hand] - wanted) < 1e-4f);
  // Outside the fade nothing moves; inside it the hand is part of the way there.
  CHECK(glm::length(motion.positions[5 * joints + hand] - before.positions[5 * joints + hand]) == 0.0f);
  const float halfway = glm::length(motion.positions[15 * joints + hand] - before.positions[15 * joints + hand]);
  const float full = glm::length(wanted - before.positions[20 * joints + hand]);
  CHECK(halfway > 0.05f * full);
  CHECK(halfway < 0.95f * full);
  for (size_t f : {15u, 20u, 25u}) {
    const glm::vec3* p = motion.positions.data() + f * joints;
    const glm::mat3* global = motion.global_rotations.data() + f * joints;
    const glm::mat3* local = motion.local_rotations.data() + f * joints;
    INFO("frame " << f);
    // Bones keep their lengths, the hand its world rotation, and the locals agree with the globals.
    CHECK(glm::length(p[lower] - p[upper]) == Catch::Approx(glm::length(skeleton.offset(lower))).margin(1e-5));
    CHECK(glm::length(p[hand] - p[lower]) == Catch::Approx(glm::length(skeleton.offset(hand))).margin(1e-5));
    CHECK(glm::length(global[hand][0] - before.global_rotations[f * joints + hand][0]) < 1e-6f);
    const glm::mat3 recomposed = global[lower] * local[hand];
    CHECK(glm::length(recomposed[1] - global[hand][1]) < 1e-5f);
    // The rest of the body is untouched.
    CHECK(glm::length(p[*skeleton.find("Hand_L")] - before.positions[f * joints + *skeleton.find("Hand_L")]) == 0.0f);
  }
}

TEST_CASE("targets of the root or of joints without two bones above them are left to the model") {
  const ardy::Skeleton skeleton = ardy_test::ardy_test_skeleton();
  ardy::Motion motion = rest_motion(skeleton, 10, 0.0f, 0.0f);
  ardy::JointTarget root, spine, rotation_only;
  root.frame = spine.frame = rotation_only.frame = 5;
  root.joint = 0;
  root.position = glm::dvec3(1.0, 1.0, 1.0);
  spine.joint = *skeleton.find("Spine");
  spine.position = glm::dvec3(0.5, 1.0, 0.0);
  rotation_only.joint = *skeleton.find("Hand_L");
  rotation_only.rotation = glm::dmat3(1.0);
  CHECK(ardy::JointReach(skeleton).apply(0, motion, {root, spine, rotation_only}) == 0);
}
