// features: the layout (default and from JSON), packing and unpacking a frame,
// normalization, patching into tokens, translation-only re-centering.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include <nlohmann/json.hpp>

#include "features.hpp"
#include "kinematics.hpp"
#include "support/error_message.hpp"
#include "support/skeletons.hpp"

using ardy::FeatureLayout;
using ardy::FeatureSlice;
using ardy::MotionFrame;
using ardy_test::error_message;
using Catch::Matchers::ContainsSubstring;
using nlohmann::json;

namespace {

// export_tools/ardy_export/data/features.py FEATURE_LAYOUT, as model.json carries it.
json python_layout() {
  return json::parse(R"({"root_position": [0, 3], "heading": [3, 5], "rotation_6d": [5, 131],
                         "joint_positions": [131, 191], "joint_velocities": [191, 254],
                         "foot_contacts": [254, 258]})");
}

MotionFrame random_frame(const ardy::Skeleton& s, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::vector<glm::mat3> local;
  for (size_t j = 0; j < s.joint_count(); ++j) {
    local.push_back(ardy::matrix_from_quat(glm::quat(normal(rng), normal(rng), normal(rng), normal(rng))));
  }
  MotionFrame f;
  f.root_position = glm::vec3(normal(rng), 0.9f + 0.1f * normal(rng), normal(rng));
  const float psi = normal(rng);
  f.heading_cos = std::cos(psi);
  f.heading_sin = std::sin(psi);
  const ardy::GlobalPose pose = ardy::forward_kinematics(s, f.root_position, local);
  f.rotations = pose.rotations;
  f.positions = pose.positions;
  for (size_t j = 0; j < s.joint_count(); ++j) f.velocities.emplace_back(normal(rng), normal(rng), normal(rng));
  f.contacts = {1.0f, 0.0f, 0.0f, 1.0f};
  return f;
}

float max_abs_diff(const glm::vec3& a, const glm::vec3& b) {
  return std::max({std::fabs(a.x - b.x), std::fabs(a.y - b.y), std::fabs(a.z - b.z)});
}

std::vector<float> iota_frames(size_t frames, size_t m) {
  std::vector<float> out(frames * m);
  std::iota(out.begin(), out.end(), 0.0f);
  return out;
}

}  // namespace

TEST_CASE("the default layout is design.md's, exactly", "[features]") {
  const FeatureLayout l = FeatureLayout::ardy_default(21);
  l.validate();
  CHECK(l.feature_size == 258);
  CHECK(l.root_position == FeatureSlice{0, 3});
  CHECK(l.heading == FeatureSlice{3, 2});
  CHECK(l.rotation_6d == FeatureSlice{5, 126});
  CHECK(l.joint_positions == FeatureSlice{131, 60});
  CHECK(l.joint_velocities == FeatureSlice{191, 63});
  CHECK(l.foot_contacts == FeatureSlice{254, 4});
  CHECK(l.root() == FeatureSlice{0, 5});
  CHECK(l.body() == FeatureSlice{5, 253});
  CHECK(l.root_size() == 5);
  CHECK(l.body_size() == 253);
  CHECK(l.rotation_6d_of(20) == FeatureSlice{125, 6});
  CHECK(l.joint_position_of(1) == FeatureSlice{131, 3});
  CHECK(l.joint_position_of(20) == FeatureSlice{188, 3});
  CHECK(l.joint_velocity_of(0) == FeatureSlice{191, 3});
  CHECK_THAT(error_message([&] { l.joint_position_of(0); }), ContainsSubstring("the root's position is root_position"));
  CHECK_THAT(error_message([&] { l.rotation_6d_of(21); }), ContainsSubstring("joint 21 out of range"));

  const FeatureLayout other = FeatureLayout::ardy_default(5, 2);  // another skeleton
  CHECK(other.feature_size == 5 + 30 + 12 + 15 + 2);
  other.validate();
}

TEST_CASE("the layout is read from the package's JSON", "[features]") {
  const FeatureLayout l = FeatureLayout::from_json(python_layout(), 21);
  CHECK(l == FeatureLayout::ardy_default(21));
  CHECK(FeatureLayout::from_json(l.to_json(), 21) == l);
  CHECK(l.to_json().at("feature_size") == 258);

  const auto refuse = [](json j, size_t joints = 21) {
    return error_message([&] { FeatureLayout::from_json(j, joints); });
  };
  json j = python_layout();
  j["tail"] = {258, 259};
  CHECK_THAT(refuse(j), ContainsSubstring("unknown slice 'tail'") && ContainsSubstring("root_position, heading"));
  j = python_layout();
  j.erase("heading");
  CHECK_THAT(refuse(j), ContainsSubstring("missing slice 'heading'"));
  j = python_layout();
  j["heading"] = {5, 3};
  CHECK_THAT(refuse(j), ContainsSubstring("slice 'heading' must be [start, stop] with 0 <= start <= stop, got [5,3]"));
  j["heading"] = "3:5";
  CHECK_THAT(refuse(j), ContainsSubstring("slice 'heading' must be [start, stop]"));
  CHECK_THAT(refuse(python_layout(), 20),
             ContainsSubstring("'rotation_6d' [5, 131) has 126 values, expected 120 (6 per joint, 20 joints)"));
  j = python_layout();
  j["feature_size"] = 300;
  CHECK_THAT(refuse(j), ContainsSubstring("feature_size is 300 but the slices end at 258"));
  j = python_layout();
  j["foot_contacts"] = {255, 259};
  CHECK_THAT(refuse(j), ContainsSubstring("features [254, 255) belong to no slice"));
  j = python_layout();
  j["foot_contacts"] = {253, 257};
  CHECK_THAT(refuse(j), ContainsSubstring("'foot_contacts' [253, 257) overlaps the slice before it"));
  // The heading after the 6D rotations instead of after the position.
  j = json::parse(R"({"root_position": [0, 3], "rotation_6d": [3, 129], "heading": [129, 131],
                      "joint_positions": [131, 191], "joint_velocities": [191, 254], "foot_contacts": [254, 258]})");
  CHECK_THAT(refuse(j), ContainsSubstring("'heading' [129, 131) must directly follow 'root_position' [0, 3)"));
  CHECK_THAT(refuse(json::array()), ContainsSubstring("expected an object of named slices"));
}

TEST_CASE("a root at the end of the frame still gives a contiguous body", "[features]") {
  const json j = json::parse(R"({"rotation_6d": [0, 126], "joint_positions": [126, 186],
                                 "joint_velocities": [186, 249], "foot_contacts": [249, 253],
                                 "root_position": [253, 256], "heading": [256, 258]})");
  const FeatureLayout l = FeatureLayout::from_json(j, 21);
  CHECK(l.root() == FeatureSlice{253, 5});
  CHECK(l.body() == FeatureSlice{0, 253});
  const ardy::Skeleton s = ardy_test::ardy_test_skeleton();
  const MotionFrame frame = random_frame(s, 5);
  std::vector<float> f(l.feature_size, -99.0f);
  ardy::pack_frame(l, frame, f.data());
  CHECK(f[253] == frame.root_position.x);
  CHECK(f[257] == frame.heading_sin);
  const MotionFrame back = ardy::unpack_frame(l, f.data());
  CHECK(max_abs_diff(back.positions[20], frame.positions[20]) < 1e-5f);
}

TEST_CASE("pack and unpack a frame", "[features]") {
  const ardy::Skeleton s = ardy_test::ardy_test_skeleton();
  const FeatureLayout l = FeatureLayout::ardy_default(s.joint_count());
  const MotionFrame frame = random_frame(s, 1);
  std::vector<float> f(l.feature_size, -99.0f);
  ardy::pack_frame(l, frame, f.data());
  for (size_t i = 0; i < f.size(); ++i) CHECK(f[i] != -99.0f);  // every feature written

  // By hand: p, heading, the 6D of joint 3, J of joint 5 relative to the planar root, velocity, contacts.
  const glm::vec3 p = frame.root_position;
  CHECK(std::vector<float>(f.begin(), f.begin() + 5) ==
        std::vector<float>{p.x, p.y, p.z, frame.heading_cos, frame.heading_sin});
  const glm::mat3& r3 = frame.rotations[3];
  CHECK(std::vector<float>(f.begin() + 23, f.begin() + 29) ==
        std::vector<float>{r3[0][0], r3[0][1], r3[0][2], r3[1][0], r3[1][1], r3[1][2]});
  const glm::vec3 j5 = frame.positions[5];
  CHECK(f[131 + 12] == j5.x - p.x);
  CHECK(f[131 + 13] == j5.y);  // height stays absolute
  CHECK(f[131 + 14] == j5.z - p.z);
  CHECK(f[191 + 3 * 7 + 1] == frame.velocities[7].y);
  CHECK(std::vector<float>(f.begin() + 254, f.end()) == frame.contacts);

  const MotionFrame back = ardy::unpack_frame(l, f.data());
  CHECK(back.root_position == p);
  CHECK(std::fabs(back.heading() - std::atan2(frame.heading_sin, frame.heading_cos)) < 1e-6f);
  for (size_t j = 0; j < s.joint_count(); ++j) {
    CAPTURE(j);
    CHECK(max_abs_diff(back.positions[j], frame.positions[j]) < 1e-5f);
    CHECK(back.velocities[j] == frame.velocities[j]);
    for (int c = 0; c < 3; ++c) CHECK(max_abs_diff(back.rotations[j][c], frame.rotations[j][c]) < 1e-5f);
  }
  CHECK(back.contacts == frame.contacts);

  MotionFrame bad = frame;
  bad.contacts.pop_back();
  CHECK_THAT(error_message([&] { ardy::pack_frame(l, bad, f.data()); }),
             ContainsSubstring("pack_frame: contacts: 3 entries, the layout needs 4"));
  bad = frame;
  bad.rotations.resize(20);
  CHECK_THAT(error_message([&] { ardy::pack_frame(l, bad, f.data()); }),
             ContainsSubstring("pack_frame: rotations: 20 entries, the layout needs 21"));
}

TEST_CASE("normalization with the package's statistics", "[features]") {
  const ardy::Normalization n({1.0f, -2.0f, 0.5f}, {2.0f, 0.5f, 4.0f});
  std::vector<float> rows{3.0f, -1.0f, 0.5f, 1.0f, -2.0f, 4.5f};
  n.normalize(rows.data(), 2);
  CHECK(rows == std::vector<float>{1.0f, 2.0f, 0.0f, 0.0f, 0.0f, 1.0f});
  n.denormalize(rows.data(), 2);
  CHECK(rows == std::vector<float>{3.0f, -1.0f, 0.5f, 1.0f, -2.0f, 4.5f});

  // Features [1, 3) in groups of two values (e.g. the root part of each frame of a token).
  std::vector<float> groups{-1.0f, 2.5f, -2.0f, 0.5f};
  n.normalize(groups.data(), 2, FeatureSlice{1, 2});
  CHECK(groups == std::vector<float>{2.0f, 0.5f, 0.0f, 0.0f});
  n.denormalize(groups.data(), 2, FeatureSlice{1, 2});
  CHECK(groups == std::vector<float>{-1.0f, 2.5f, -2.0f, 0.5f});
  CHECK_THAT(error_message([&] { n.normalize(groups.data(), 1, FeatureSlice{2, 2}); }),
             ContainsSubstring("features [2, 4) are outside the 3 statistics"));

  CHECK_THAT(error_message([] { ardy::Normalization({1, 2}, {1}, "body stats"); }),
             ContainsSubstring("body stats: mean has 2 values but std has 1"));
  CHECK_THAT(error_message([] { ardy::Normalization({1, 2}, {1, 0}); }),
             ContainsSubstring("std[1] is 0.000000; standard deviations must be finite and positive"));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  CHECK_THAT(error_message([&] { ardy::Normalization({nan}, {1}); }), ContainsSubstring("mean[0] is not finite"));
  CHECK_THAT(error_message([] { ardy::Normalization({}, {}); }), ContainsSubstring("no statistics"));
}

TEST_CASE("patching: roots of P frames frame-major, hybrid tokens, and back", "[features]") {
  const FeatureLayout l = FeatureLayout::ardy_default(21);
  const size_t patch = 4;
  const size_t frames = 8;
  const std::vector<float> f = iota_frames(frames, l.feature_size);  // f[t][i] = 258 t + i
  const std::vector<float> roots = ardy::gather_root_tokens(l, f.data(), frames, patch);
  REQUIRE(roots.size() == 2 * 20);
  // Token 1 holds frames 4..7: (p.x, p.y, p.z, cos, sin) of frame 4, then frame 5, ...
  CHECK(roots[20] == 258.0f * 4);
  CHECK(roots[24] == 258.0f * 4 + 4);
  CHECK(roots[25] == 258.0f * 5);
  CHECK(roots[39] == 258.0f * 7 + 4);

  std::vector<float> copy(f.size(), 0.0f);
  ardy::scatter_root_tokens(l, roots.data(), 2, patch, copy.data());
  for (size_t t = 0; t < frames; ++t) {
    for (size_t i = 0; i < 5; ++i) CHECK(copy[t * 258 + i] == f[t * 258 + i]);
    CHECK(copy[t * 258 + 5] == 0.0f);  // the body is not touched
  }
  CHECK_THAT(error_message([&] { ardy::gather_root_tokens(l, f.data(), 7, patch); }),
             ContainsSubstring("7 frames is not a multiple of the patch size 4"));

  const std::vector<float> latents{0.1f, 0.2f, 0.3f, 1.1f, 1.2f, 1.3f};  // L = 3
  const std::vector<float> tokens = ardy::make_hybrid_tokens(l, roots.data(), latents.data(), 2, patch, 3);
  REQUIRE(tokens.size() == 2 * 23);
  CHECK(tokens[20] == 0.1f);
  CHECK(tokens[23] == roots[20]);
  CHECK(tokens[45] == 1.3f);
  std::vector<float> roots_back;
  std::vector<float> latents_back;
  ardy::split_hybrid_tokens(l, tokens.data(), 2, patch, 3, roots_back, latents_back);
  CHECK(roots_back == roots);
  CHECK(latents_back == latents);
}

TEST_CASE("re-centering moves x and z of the root only, and un-centering undoes it", "[features]") {
  const FeatureLayout l = FeatureLayout::ardy_default(21);
  std::vector<float> f = iota_frames(4, l.feature_size);
  const std::vector<float> original = f;
  const glm::vec3 offset = ardy::planar_root_offset(l, f.data(), 4, 3);
  CHECK(offset == glm::vec3(258.0f * 3, 0.0f, 258.0f * 3 + 2));
  ardy::recenter_frames(l, f.data(), 4, offset);
  CHECK(f[3 * 258 + 0] == 0.0f);  // the anchor frame's root is at x = z = 0
  CHECK(f[3 * 258 + 2] == 0.0f);
  CHECK(f[3 * 258 + 1] == original[3 * 258 + 1]);  // height untouched
  CHECK(f[0] == original[0] - offset.x);
  for (size_t t = 0; t < 4; ++t) {
    for (size_t i = 3; i < 258; ++i) CHECK(f[t * 258 + i] == original[t * 258 + i]);  // heading, body untouched
  }
  ardy::uncenter_frames(l, f.data(), 4, offset);
  CHECK(f == original);
  CHECK_THAT(error_message([&] { ardy::planar_root_offset(l, f.data(), 4, 4); }),
             ContainsSubstring("anchor frame 4 out of range (4 frames)"));

  // Tokens of 2 frames (P = 2) with a latent of 1: [root f0 (5), root f1 (5), latent].
  std::vector<float> tokens{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  ardy::recenter_token_roots(l, tokens.data(), 1, 11, 2, glm::vec3(1.0f, 100.0f, 3.0f));
  CHECK(tokens == std::vector<float>{0, 2, 0, 4, 5, 5, 7, 5, 9, 10, 11});
  ardy::uncenter_token_roots(l, tokens.data(), 1, 11, 2, glm::vec3(1.0f, 100.0f, 3.0f));
  CHECK(tokens == std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
  CHECK_THAT(error_message([&] { ardy::recenter_token_roots(l, tokens.data(), 1, 9, 2, glm::vec3(0.0f)); }),
             ContainsSubstring("tokens of 9 values cannot hold the roots of 2 frames (10 values)"));
}
