// Foot locking (foot_lock.hpp) and the two-bone IK under it (kinematics.hpp),
// on the tiny package's skeleton: a body gliding forward with a foot marked
// planted must leave that foot where it landed, legs intact.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "foot_lock.hpp"
#include "kinematics.hpp"
#include "package.hpp"
#include "sampler.hpp"
#include "support/goldens.hpp"

using ardy::FootLocker;
using ardy::FootLockState;
using ardy::Motion;
using ardy_test::tiny_package;
using Catch::Matchers::WithinAbs;

namespace {

// World features of a body standing with slightly bent knees (thighs 20
// degrees forward, shins 20 degrees back), gliding along +z at `speed` m/s;
// the left foot's flags are `left_flag(frame)`, the right foot's 0.
template <typename Flag>
std::vector<float> gliding(size_t frames, double speed, Flag left_flag) {
  const ardy::ModelPackage& p = *tiny_package();
  const ardy::FeatureLayout& layout = p.layout();
  const size_t m = layout.feature_size;
  std::vector<float> out(frames * m, 0.0f);
  for (size_t f = 0; f < frames; ++f) {
    float* row = out.data() + f * m;
    row[layout.root_position.start + 1] = 0.9f;
    row[layout.root_position.start + 2] = float(speed * double(f) / p.fps());
    row[layout.heading.start] = 1.0f;
    for (size_t j = 0; j < layout.joint_count; ++j) {
      const std::string& name = p.skeleton().name(j);
      float bend = 0.0f;
      if (name.rfind("UpperLeg", 0) == 0) bend = -0.35f;
      if (name.rfind("LowerLeg", 0) == 0) bend = 0.35f;
      ardy::rotation_to_6d(ardy::rotation_about(glm::vec3(1, 0, 0), bend), row + layout.rotation_6d_of(j).start);
    }
    row[layout.foot_contacts.start + 0] = left_flag(f);  // Foot_L
    row[layout.foot_contacts.start + 1] = left_flag(f);  // Toes_L
  }
  return out;
}

Motion motion_of(const std::vector<float>& features) {
  const ardy::ModelPackage& p = *tiny_package();
  Motion motion;
  ardy::features_to_motion(p.skeleton(), p.layout(), features.data(), features.size() / p.layout().feature_size, motion);
  return motion;
}

glm::vec3 joint(const Motion& motion, size_t frame, const char* name) {
  return motion.positions_of(frame)[tiny_package()->skeleton().index_of(name)];
}

}  // namespace

TEST_CASE("two-bone IK puts the ankle on the target, keeps the bones and the knee's side", "[foot_lock][kinematics]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 200; ++trial) {
    const glm::vec3 a(u(rng), 1.0f + u(rng) * 0.1f, u(rng));
    const glm::vec3 b = a + glm::vec3(0.1f * u(rng), -0.45f, 0.15f + 0.05f * u(rng));
    const glm::vec3 c = b + glm::vec3(0.1f * u(rng), -0.42f, -0.2f + 0.05f * u(rng));
    const float reach = 0.2f + 0.6f * (u(rng) * 0.5f + 0.5f);  // 0.2 .. 0.8 of 0.87 m of leg
    const glm::vec3 direction = glm::normalize(glm::vec3(0.3f * u(rng), -1.0f, 0.3f * u(rng)));
    const glm::vec3 target = a + direction * reach;
    const ardy::TwoBoneRotations r = ardy::two_bone_ik(a, b, c, target, glm::vec3(1, 0, 0));
    const glm::vec3 b2 = a + r.upper * (b - a);
    const glm::vec3 c2 = b2 + r.lower * (c - b);
    INFO("trial " << trial);
    CHECK(glm::length(c2 - target) < 1e-3f);
    CHECK_THAT(glm::length(b2 - a), WithinAbs(glm::length(b - a), 1e-4));
    CHECK_THAT(glm::length(c2 - b2), WithinAbs(glm::length(c - b), 1e-4));
    // The knee bends the same way relative to the limb as before.
    const glm::vec3 before = glm::cross(b - a, c - b), after = glm::cross(b2 - a, c2 - b2);
    CHECK(glm::dot(glm::normalize(before), glm::normalize(after)) > 0.0f);
  }
  // Out of reach: as far as the limb goes, toward the target, never straight.
  const glm::vec3 a(0, 1, 0), b(0, 0.55f, 0.05f), c(0, 0.1f, 0);
  const ardy::TwoBoneRotations far = ardy::two_bone_ik(a, b, c, glm::vec3(0, -2, 0), glm::vec3(1, 0, 0));
  const glm::vec3 b2 = a + far.upper * (b - a), c2 = b2 + far.lower * (c - b);
  CHECK(c2.x == Catch::Approx(0.0f).margin(1e-4));
  CHECK(glm::length(c2 - a) < glm::length(b - a) + glm::length(c - b));
  CHECK(glm::length(c2 - a) > 0.99f * (glm::length(b - a) + glm::length(c - b)));
}

TEST_CASE("a planted foot stays where it landed while the body glides on, then rejoins its path",
          "[foot_lock]") {
  const ardy::ModelPackage& p = *tiny_package();
  const FootLocker locker(p.skeleton(), p.layout(), p.contact_joints());
  REQUIRE(locker.available());
  const size_t frames = 30, planted = 10;  // left foot planted on frames 0..9
  const std::vector<float> features = gliding(frames, 0.4, [&](size_t f) { return f < planted ? 1.0f : 0.0f; });
  const Motion own = motion_of(features);
  Motion locked = own;
  FootLockState state;
  std::vector<FootLockState> states;
  locker.apply(features.data(), locked, state, &states);
  REQUIRE(states.size() == frames);

  const glm::vec3 landed = joint(own, 0, "Foot_L");
  for (size_t f = 0; f < planted; ++f) {
    INFO("frame " << f);
    const glm::vec3 ankle = joint(locked, f, "Foot_L");
    // The hold eases in over kFootPlantFrames, then the ankle stays put.
    if (f > ardy::kFootPlantFrames) CHECK(glm::length(glm::vec2(ankle.x, ankle.z) - glm::vec2(landed.x, landed.z)) < 1e-3f);
    CHECK_THAT(ankle.y, WithinAbs(joint(own, f, "Foot_L").y, 1e-3));  // height as the model had it
    CHECK(joint(locked, f, "Hips") == joint(own, f, "Hips"));
    CHECK(glm::length(joint(locked, f, "Foot_R") - joint(own, f, "Foot_R")) < 1e-6f);  // not planted
    // The leg keeps its bone lengths.
    const auto bone = [&](const Motion& mo, const char* x, const char* y) {
      return glm::length(joint(mo, f, x) - joint(mo, f, y));
    };
    CHECK_THAT(bone(locked, "UpperLeg_L", "LowerLeg_L"), WithinAbs(bone(own, "UpperLeg_L", "LowerLeg_L"), 1e-4));
    CHECK_THAT(bone(locked, "LowerLeg_L", "Foot_L"), WithinAbs(bone(own, "LowerLeg_L", "Foot_L"), 1e-4));
    CHECK_THAT(bone(locked, "Foot_L", "Toes_L"), WithinAbs(bone(own, "Foot_L", "Toes_L"), 1e-4));
  }
  // Lifted: back on the model's path, never faster than the model's own foot
  // allows (issue 15: a fixed 6-frame return jumped; the return's bound is
  // kFootReturnShare of the model's step plus kFootReturnFloorStep a frame).
  const float own_step = 0.4f / float(p.fps());  // the body glides 0.02 m a frame
  size_t back = frames;
  for (size_t f = planted; f < frames; ++f) {
    INFO("frame " << f);
    const float error = glm::length(joint(locked, f, "Foot_L") - joint(own, f, "Foot_L"));
    if (error < 1e-6f) back = std::min(back, f);
    if (back < f) CHECK(error < 1e-6f);  // and stays on it
    const float step = glm::length(joint(locked, f, "Foot_L") - joint(locked, f - 1, "Foot_L"));
    CHECK(step <= (1.0f + ardy::kFootReturnShare) * own_step + ardy::kFootReturnFloorStep + 1e-4f);
  }
  // The hold left it about 0.16 m behind: a few frames more than the cap's pace.
  CHECK(back <= planted + 2 * ardy::kFootReleaseFrames);

  // Two calls with the state carried over give the same frames as one.
  Motion first = motion_of(std::vector<float>(features.begin(), features.begin() + 6 * p.layout().feature_size));
  Motion second = motion_of(std::vector<float>(features.begin() + 6 * p.layout().feature_size, features.end()));
  FootLockState carried;
  locker.apply(features.data(), first, carried);
  locker.apply(features.data() + 6 * p.layout().feature_size, second, carried);
  for (size_t f = 0; f < frames; ++f) {
    const glm::vec3 split = f < 6 ? joint(first, f, "Foot_L") : joint(second, f - 6, "Foot_L");
    CHECK(glm::length(split - joint(locked, f, "Foot_L")) < 1e-6f);
  }
}

TEST_CASE("a constrained leg is not held: the foot returns to the model's path before the constraint",
          "[foot_lock]") {
  const ardy::ModelPackage& p = *tiny_package();
  const ardy::FeatureLayout& layout = p.layout();
  const FootLocker locker(p.skeleton(), layout, p.contact_joints());
  const size_t frames = 20, target = 12;  // a goal on the left ankle's position at frame 12
  const std::vector<float> features = gliding(frames, 0.3, [](size_t) { return 1.0f; });
  std::vector<float> goal_mask(frames * layout.feature_size, 0.0f);
  const ardy::FeatureSlice ankle = layout.joint_position_of(p.skeleton().index_of("Foot_L"));
  for (size_t i = 0; i < ankle.size; ++i) goal_mask[target * layout.feature_size + ankle.start + i] = 1.0f;
  const Motion own = motion_of(features);
  Motion locked = own;
  FootLockState state;
  std::vector<FootLockState> states;
  locker.apply(features.data(), locked, state, &states, goal_mask.data());
  CHECK(states[target - ardy::kFootReleaseFrames - 1].legs[0].planted);  // held until the return must start
  for (size_t f = target - ardy::kFootReleaseFrames; f <= target; ++f) CHECK_FALSE(states[f].legs[0].planted);
  CHECK(glm::length(joint(locked, target, "Foot_L") - joint(own, target, "Foot_L")) < 1e-6f);  // the goal's frame as generated
  CHECK(states.back().legs[0].planted);  // held again after it
}

TEST_CASE("flags wavering around one half do not make a held foot flicker", "[foot_lock]") {
  const ardy::ModelPackage& p = *tiny_package();
  const FootLocker locker(p.skeleton(), p.layout(), p.contact_joints());
  // Planted firmly, then the flags waver between 0.45 and 0.55: still held.
  const std::vector<float> features =
      gliding(20, 0.2, [](size_t f) { return f < 4 ? 1.0f : (f % 2 ? 0.45f : 0.55f); });
  Motion locked = motion_of(features);
  FootLockState state;
  std::vector<FootLockState> states;
  locker.apply(features.data(), locked, state, &states);
  for (const FootLockState& s : states) CHECK(s.legs[0].planted);
  // Lifted for two frames, then planted again mid-return: held where it is
  // shown, without stepping back toward the model's path.
  const std::vector<float> again = gliding(16, 0.4, [](size_t f) { return f == 8 || f == 9 ? 0.0f : 1.0f; });
  Motion replanted = motion_of(again);
  FootLockState fresh;
  locker.apply(again.data(), replanted, fresh);
  for (size_t f = 1; f < 16; ++f) {
    INFO("frame " << f);
    CHECK(glm::length(joint(replanted, f, "Foot_L") - joint(replanted, f - 1, "Foot_L")) < 0.05f);
  }
  // A foot lifted high is never held, whatever its flags say.
  std::vector<float> high = gliding(8, 0.4, [](size_t) { return 1.0f; });
  for (size_t f = 0; f < 8; ++f) high[f * p.layout().feature_size + p.layout().root_position.start + 1] = 1.5f;
  Motion raised = motion_of(high);
  const Motion own = raised;
  FootLockState none;
  locker.apply(high.data(), raised, none);
  CHECK(raised.positions == own.positions);
}

TEST_CASE("a foot let go while still down is held again once back on the model's path", "[foot_lock]") {
  // A standing model whose planted foot drifts (waving, say): flags down
  // throughout, the body sliding 0.3 m/s. The hold lets go at
  // kFootLockMaxPull, the foot returns to the model's path, then is held
  // again: most frames held, not a foot that slides on once let go.
  const ardy::ModelPackage& p = *tiny_package();
  const FootLocker locker(p.skeleton(), p.layout(), p.contact_joints());
  const size_t frames = 80;
  const std::vector<float> features = gliding(frames, 0.3, [](size_t) { return 1.0f; });
  Motion locked = motion_of(features);
  FootLockState state;
  std::vector<FootLockState> states;
  locker.apply(features.data(), locked, state, &states);
  size_t held = 0, holds = 0;
  for (size_t f = 0; f < frames; ++f) {
    if (states[f].legs[0].planted) ++held;
    if (states[f].legs[0].planted && (f == 0 || !states[f - 1].legs[0].planted)) ++holds;
  }
  INFO(held << " of " << frames << " frames held, in " << holds << " holds");
  CHECK(holds >= 2);
  CHECK(held >= frames / 2);
  // The let-go foot moves no faster than the return's bound.
  const float own_step = 0.3f / float(p.fps());
  for (size_t f = 1; f < frames; ++f) {
    INFO("frame " << f);
    const float step = glm::length(joint(locked, f, "Foot_L") - joint(locked, f - 1, "Foot_L"));
    CHECK(step <= (1.0f + ardy::kFootReturnShare) * own_step + ardy::kFootReturnFloorStep + 1e-4f);
  }
}
