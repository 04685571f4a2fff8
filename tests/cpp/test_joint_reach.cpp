// joint_reach: a hand target reached exactly at its frame by two-bone IK,
// blended in and out around it, bones kept at their lengths; a foot turned to
// a rotation target with its toes.

#include <catch_amalgamated.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

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

TEST_CASE("a rotation target turns the joint and the joints below it, blended in and out") {
  const ardy::Skeleton skeleton = ardy_test::ardy_test_skeleton();
  const size_t foot = *skeleton.find("Foot_L"), toes = *skeleton.find("Toes_L");
  const size_t joints = skeleton.joint_count();
  ardy::Motion motion = rest_motion(skeleton, 40, 0.5f, 0.0f);
  const ardy::Motion before = motion;
  ardy::JointTarget target;
  target.frame = 20;
  target.joint = foot;
  // 60 degrees about the left-right axis (toes up), in world space.
  const glm::mat3 wanted = glm::mat3(glm::angleAxis(glm::radians(60.0f), glm::vec3(1.0f, 0.0f, 0.0f)));
  target.rotation = glm::dmat3(wanted);
  const size_t changed = ardy::JointReach(skeleton).apply(0, motion, {target});
  CHECK(changed == static_cast<size_t>(2 * ardy::kReachFadeFrames + 1));

  const auto angle_between = [](const glm::mat3& a, const glm::mat3& b) {
    const glm::mat3 d = glm::transpose(a) * b;
    return std::acos(std::clamp((d[0][0] + d[1][1] + d[2][2] - 1.0f) * 0.5f, -1.0f, 1.0f));
  };
  CHECK(angle_between(motion.global_rotations[20 * joints + foot], wanted) < 1e-3f);
  // The foot turns about itself; its toes turn with it, at the same bone length.
  CHECK(glm::length(motion.positions[20 * joints + foot] - before.positions[20 * joints + foot]) < 1e-6f);
  CHECK(glm::length(motion.positions[20 * joints + toes] - before.positions[20 * joints + toes]) > 0.01f);
  CHECK(glm::length(motion.positions[20 * joints + toes] - motion.positions[20 * joints + foot]) ==
        Catch::Approx(glm::length(skeleton.offset(toes))).margin(1e-5));
  CHECK(angle_between(motion.global_rotations[20 * joints + toes], wanted * before.global_rotations[20 * joints + toes]) <
        1e-3f);
  // Halfway through the fade part of the turn is made; outside it nothing moves.
  const float halfway = angle_between(motion.global_rotations[15 * joints + foot], before.global_rotations[15 * joints + foot]);
  CHECK(halfway > 0.05f * glm::radians(60.0f));
  CHECK(halfway < 0.95f * glm::radians(60.0f));
  CHECK(angle_between(motion.global_rotations[5 * joints + foot], before.global_rotations[5 * joints + foot]) == 0.0f);
  // The locals agree with the globals; the other leg is untouched.
  const glm::mat3 recomposed = motion.global_rotations[20 * joints + foot] * motion.local_rotations[20 * joints + toes];
  CHECK(glm::length(recomposed[1] - motion.global_rotations[20 * joints + toes][1]) < 1e-5f);
  const size_t right = *skeleton.find("Foot_R");
  CHECK(glm::length(motion.positions[20 * joints + right] - before.positions[20 * joints + right]) == 0.0f);
}

TEST_CASE("targets of the root or of joints without two bones above them are left to the model") {
  const ardy::Skeleton skeleton = ardy_test::ardy_test_skeleton();
  ardy::Motion motion = rest_motion(skeleton, 10, 0.0f, 0.0f);
  ardy::JointTarget root, spine, already_turned;
  root.frame = spine.frame = already_turned.frame = 5;
  root.joint = 0;
  root.position = glm::dvec3(1.0, 1.0, 1.0);
  spine.joint = *skeleton.find("Spine");
  spine.position = glm::dvec3(0.5, 1.0, 0.0);
  // A rotation target the joint already has moves nothing either.
  already_turned.joint = *skeleton.find("Hand_L");
  already_turned.rotation = glm::dmat3(motion.global_rotations[5 * skeleton.joint_count() + already_turned.joint]);
  CHECK(ardy::JointReach(skeleton).apply(0, motion, {root, spine, already_turned}) == 0);
}
