// kinematics: 6D <-> matrix <-> quaternion, slerp, heading, global <-> local,
// forward kinematics; identities, round trips and hand-computed cases.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <random>
#include <vector>

#include "kinematics.hpp"
#include "support/error_message.hpp"
#include "support/skeletons.hpp"

using ardy_test::error_message;
using Catch::Matchers::ContainsSubstring;

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kTol = 1e-5f;

float max_abs_diff(const glm::mat3& a, const glm::mat3& b) {
  float worst = 0.0f;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) worst = std::max(worst, std::fabs(a[c][r] - b[c][r]));
  }
  return worst;
}

float max_abs_diff(const glm::vec3& a, const glm::vec3& b) {
  return std::max({std::fabs(a.x - b.x), std::fabs(a.y - b.y), std::fabs(a.z - b.z)});
}

bool is_rotation(const glm::mat3& r) {
  return max_abs_diff(glm::transpose(r) * r, glm::mat3(1.0f)) < 1e-5f && std::fabs(glm::determinant(r) - 1.0f) < 1e-5f;
}

// Deterministic random rotations (uniform via normalized Gaussian quaternions).
std::vector<glm::mat3> random_rotations(size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::vector<glm::mat3> out;
  for (size_t i = 0; i < count; ++i) {
    out.push_back(ardy::matrix_from_quat(glm::quat(normal(rng), normal(rng), normal(rng), normal(rng))));
  }
  return out;
}

// Rotation about an axis by an angle, written out (Rodrigues) independently of the code under test.
glm::mat3 axis_angle(glm::vec3 axis, float angle) {
  axis = glm::normalize(axis);
  const float c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  const float x = axis.x, y = axis.y, z = axis.z;
  glm::mat3 r(1.0f);
  r[0] = glm::vec3(t * x * x + c, t * x * y + s * z, t * x * z - s * y);  // column 0
  r[1] = glm::vec3(t * x * y - s * z, t * y * y + c, t * y * z + s * x);
  r[2] = glm::vec3(t * x * z + s * y, t * y * z - s * x, t * z * z + c);
  return r;
}

}  // namespace

TEST_CASE("6D is the first two columns, column-major, and comes back by Gram-Schmidt", "[kinematics]") {
  glm::mat3 r(1.0f);
  r[0] = glm::vec3(0.0f, 1.0f, 0.0f);  // column 0
  r[1] = glm::vec3(-1.0f, 0.0f, 0.0f);
  r[2] = glm::vec3(0.0f, 0.0f, 1.0f);
  float six[6];
  ardy::rotation_to_6d(r, six);
  CHECK(std::vector<float>(six, six + 6) == std::vector<float>{0, 1, 0, -1, 0, 0});  // (r00, r10, r20, r01, r11, r21)
  CHECK(max_abs_diff(ardy::rotation_from_6d(six), r) == 0.0f);

  // Not orthonormal: a = (2, 0, 0), b = (1, 3, 0) -> columns x, y, z.
  const float skewed[6] = {2, 0, 0, 1, 3, 0};
  CHECK(max_abs_diff(ardy::rotation_from_6d(skewed), glm::mat3(1.0f)) < kTol);

  for (const glm::mat3& m : random_rotations(200, 7)) {
    float v[6];
    ardy::rotation_to_6d(m, v);
    CHECK(max_abs_diff(ardy::rotation_from_6d(v), m) < kTol);
  }

  // Degenerate inputs still give a proper rotation.
  const float zeros[6] = {0, 0, 0, 0, 0, 0};
  const float parallel[6] = {0, 0, 3, 0, 0, -1};
  CHECK(is_rotation(ardy::rotation_from_6d(zeros)));
  CHECK(is_rotation(ardy::rotation_from_6d(parallel)));
  CHECK(ardy::rotation_from_6d(parallel)[0] == glm::vec3(0, 0, 1));
}

TEST_CASE("quaternions: known rotations, w >= 0, round trips including 180 degrees", "[kinematics]") {
  // 90 degrees about +Y: turns +Z towards +X.
  const float h = std::sqrt(0.5f);
  const glm::mat3 ry = ardy::matrix_from_quat(glm::quat(h, 0, h, 0));
  CHECK(max_abs_diff(ry * glm::vec3(0, 0, 1), glm::vec3(1, 0, 0)) < kTol);
  CHECK(max_abs_diff(ry, axis_angle({0, 1, 0}, kPi / 2)) < kTol);
  const glm::quat q = ardy::quat_from_matrix(ry);
  CHECK(std::fabs(q.w - h) < kTol);
  CHECK(std::fabs(q.y - h) < kTol);
  CHECK(max_abs_diff(ardy::matrix_from_quat(glm::quat(2, 0, 0, 0)), glm::mat3(1.0f)) == 0.0f);  // normalized first

  for (const glm::vec3& axis : {glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1), glm::vec3(1, 1, 0)}) {
    const glm::mat3 half_turn = axis_angle(axis, kPi);  // trace -1: the w candidate is useless
    const glm::quat hq = ardy::quat_from_matrix(half_turn);
    CHECK(hq.w >= 0.0f);
    CHECK(max_abs_diff(ardy::matrix_from_quat(hq), half_turn) < kTol);
  }
  for (const glm::mat3& m : random_rotations(200, 11)) {
    const glm::quat mq = ardy::quat_from_matrix(m);
    CHECK(mq.w >= 0.0f);
    CHECK(std::fabs(glm::length(mq) - 1.0f) < kTol);
    CHECK(max_abs_diff(ardy::matrix_from_quat(mq), m) < kTol);
  }
}

TEST_CASE("slerp: endpoints, constant speed, the shorter arc", "[kinematics]") {
  const glm::mat3 a = axis_angle({0, 1, 0}, 0.2f);
  const glm::mat3 b = axis_angle({0, 1, 0}, 1.4f);
  CHECK(max_abs_diff(ardy::slerp_rotation(a, b, 0.0f), a) < kTol);
  CHECK(max_abs_diff(ardy::slerp_rotation(a, b, 1.0f), b) < kTol);
  CHECK(max_abs_diff(ardy::slerp_rotation(a, b, 0.25f), axis_angle({0, 1, 0}, 0.5f)) < kTol);
  CHECK(max_abs_diff(ardy::slerp_rotation(a, a, 0.7f), a) < kTol);
  // From +170 to -170 degrees the short way goes through 180, not through 0.
  const glm::mat3 p = axis_angle({0, 0, 1}, 170.0f * kPi / 180.0f);
  const glm::mat3 n = axis_angle({0, 0, 1}, -170.0f * kPi / 180.0f);
  CHECK(max_abs_diff(ardy::slerp_rotation(p, n, 0.5f), axis_angle({0, 0, 1}, kPi)) < kTol);
  // A quaternion and its negation are the same rotation: no detour.
  const glm::quat q0 = ardy::quat_from_matrix(a);
  const glm::quat q1 = -ardy::quat_from_matrix(b);
  CHECK(max_abs_diff(ardy::matrix_from_quat(ardy::slerp_shortest(q0, q1, 0.5f)), axis_angle({0, 1, 0}, 0.8f)) < kTol);

  std::vector<glm::mat3> out;
  ardy::interpolate_rotations({a, b}, {b, a}, 0.5f, out);
  REQUIRE(out.size() == 2);
  CHECK(max_abs_diff(out[0], axis_angle({0, 1, 0}, 0.8f)) < kTol);
  std::vector<glm::vec3> positions;
  ardy::interpolate_positions({{0, 0, 0}, {1, 2, 3}}, {{2, 0, 0}, {1, 2, 5}}, 0.25f, positions);
  CHECK(positions == std::vector<glm::vec3>{{0.5f, 0, 0}, {1, 2, 3.5f}});
  CHECK_THAT(error_message([&] { ardy::interpolate_rotations({a}, {a, b}, 0.5f, out); }),
             ContainsSubstring("1 and 2 rotations"));
}

TEST_CASE("heading: psi = 0 faces +Z, positive psi turns +Z towards +X", "[kinematics]") {
  CHECK(max_abs_diff(ardy::heading_rotation(0.0f), glm::mat3(1.0f)) < kTol);
  CHECK(max_abs_diff(ardy::heading_rotation(kPi / 2) * glm::vec3(0, 0, 1), glm::vec3(1, 0, 0)) < kTol);
  CHECK(max_abs_diff(ardy::heading_rotation(0.3f), axis_angle({0, 1, 0}, 0.3f)) < kTol);
  CHECK(std::fabs(ardy::heading_angle(std::cos(2.5f), std::sin(2.5f)) - 2.5f) < kTol);
  CHECK(std::fabs(ardy::heading_angle(0.0f, 2.0f) - kPi / 2) < kTol);  // need not be unit
}

TEST_CASE("forward kinematics on a hand-computed chain", "[kinematics]") {
  const ardy::Skeleton chain = ardy_test::chain_skeleton();
  // Root turned 90 degrees about +Z (+Y -> -X), joint a turned back -90 degrees.
  const std::vector<glm::mat3> local{axis_angle({0, 0, 1}, kPi / 2), axis_angle({0, 0, 1}, -kPi / 2),
                                     glm::mat3(1.0f)};
  const ardy::GlobalPose pose = ardy::forward_kinematics(chain, {1, 2, 3}, local);
  REQUIRE(pose.positions.size() == 3);
  CHECK(max_abs_diff(pose.positions[0], {1, 2, 3}) < kTol);
  CHECK(max_abs_diff(pose.positions[1], {0, 2, 3}) < kTol);  // root's +Y bone points to -X
  CHECK(max_abs_diff(pose.positions[2], {0, 3, 3}) < kTol);  // a's world rotation is identity
  CHECK(max_abs_diff(pose.rotations[1], glm::mat3(1.0f)) < kTol);
  CHECK(max_abs_diff(pose.rotations[2], glm::mat3(1.0f)) < kTol);

  // Identity rotations give the rest pose: offsets summed along the chain.
  const ardy::Skeleton s = ardy_test::ardy_test_skeleton();
  const ardy::GlobalPose rest =
      ardy::forward_kinematics(s, {0, 1, 0}, std::vector<glm::mat3>(s.joint_count(), glm::mat3(1.0f)));
  CHECK(max_abs_diff(rest.positions[4], {0, 1.6f, 0}) < kTol);  // Hips + Spine + Chest + Neck + Head
  CHECK(max_abs_diff(rest.positions[16], {0.1f, 0.1f, 0.1f}) < kTol);
}

TEST_CASE("global <-> local round trip, and FK positions from global rotations", "[kinematics]") {
  const ardy::Skeleton s = ardy_test::ardy_test_skeleton();
  const std::vector<glm::mat3> local = random_rotations(s.joint_count(), 3);
  std::vector<glm::mat3> global;
  std::vector<glm::mat3> back;
  ardy::local_to_global(s, local, global);
  ardy::global_to_local(s, global, back);
  for (size_t j = 0; j < s.joint_count(); ++j) CHECK(max_abs_diff(back[j], local[j]) < 1e-4f);
  // global[j] = global[parent] * local[j]
  CHECK(max_abs_diff(global[8], global[7] * local[8]) < 1e-5f);

  const ardy::GlobalPose pose = ardy::forward_kinematics(s, {0.5f, 0.9f, -2}, local);
  std::vector<glm::vec3> positions;
  ardy::joint_positions(s, {0.5f, 0.9f, -2}, global, positions);
  for (size_t j = 0; j < s.joint_count(); ++j) CHECK(max_abs_diff(positions[j], pose.positions[j]) < 1e-5f);
  // Bone lengths are kept.
  for (size_t j = 1; j < s.joint_count(); ++j) {
    const float bone = glm::length(positions[j] - positions[static_cast<size_t>(s.parent(j))]);
    CHECK(std::fabs(bone - glm::length(s.offset(j))) < 1e-5f);
  }
  // Reused output vectors: calling again with the same outputs gives the same result.
  ardy::GlobalPose reused = pose;
  ardy::forward_kinematics(s, {0.5f, 0.9f, -2}, local, reused);
  CHECK(reused.positions == pose.positions);

  CHECK_THAT(error_message([&] { ardy::local_to_global(s, std::vector<glm::mat3>(20, glm::mat3(1.0f)), global); }),
             ContainsSubstring("local_to_global: local rotations: 20 entries for a skeleton of 21 joints"));
  CHECK_THAT(error_message([&] { ardy::joint_positions(s, {}, {}, positions); }),
             ContainsSubstring("joint_positions: global rotations: 0 entries"));
}
