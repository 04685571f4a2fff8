// The output filter (motion_filter.hpp): what it keeps, what it smooths.

#include <catch_amalgamated.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "features.hpp"
#include "motion_filter.hpp"
#include "sampler.hpp"

using Catch::Approx;

namespace {

const ardy::FeatureLayout kLayout = ardy::FeatureLayout::ardy_default(21);

// Frames whose every feature is a * frame + b (heading (1, 0), contacts 0/1 alternating).
std::vector<float> ramp(size_t frames, double a, double b, long long first = 0) {
  const size_t m = kLayout.feature_size;
  std::vector<float> out(frames * m);
  for (size_t f = 0; f < frames; ++f) {
    for (size_t c = 0; c < m; ++c) out[f * m + c] = static_cast<float>(a * double(first + long(f)) + b + 0.01 * c);
    out[f * m + kLayout.heading.start] = 1.0f;
    out[f * m + kLayout.heading.start + 1] = 0.0f;
    for (size_t c = 0; c < kLayout.contact_count(); ++c) out[f * m + kLayout.foot_contacts.start + c] = float((f + c) % 2);
  }
  return out;
}

double column_jerk(const std::vector<float>& x, size_t column) {
  const size_t m = kLayout.feature_size, frames = x.size() / m;
  double total = 0.0;
  for (size_t f = 3; f < frames; ++f) {
    const auto v = [&](size_t k) { return double(x[k * m + column]); };
    total += std::abs(v(f) - 3 * v(f - 1) + 3 * v(f - 2) - v(f - 3));
  }
  return total / double(frames - 3);
}

}  // namespace

TEST_CASE("sigma 0 copies the frames", "[motion_filter]") {
  const std::vector<float> in = ramp(12, 0.3, 1.0);
  CHECK(ardy::smoothing_radius(0.0) == 0);
  CHECK(ardy::smooth_features(kLayout, nullptr, 0, in.data(), 12, 0.0) == in);
}

TEST_CASE("a linear motion with its past as context passes unchanged, up to the open end",
          "[motion_filter]") {
  const size_t m = kLayout.feature_size;
  const std::vector<float> past = ramp(10, 0.05, 1.0, 0);
  const std::vector<float> now = ramp(20, 0.05, 1.0, 10);
  const double sigma = 1.5;
  const size_t radius = ardy::smoothing_radius(sigma);
  REQUIRE(radius == 5);
  const std::vector<float> out = ardy::smooth_features(kLayout, past.data(), 10, now.data(), 20, sigma);
  const size_t column = kLayout.joint_positions.start + 7;
  // A Gaussian keeps straight lines, and the point reflection past the last frame continues
  // them: every frame stays where it was (no slowing down at the window's end).
  for (size_t f = 0; f < 20; ++f) CHECK(out[f * m + column] == Approx(now[f * m + column]).margin(1e-5));
  // Contacts are flags: never blended.
  for (size_t f = 0; f < 20; ++f) {
    for (size_t c = 0; c < kLayout.contact_count(); ++c) {
      const size_t at = f * m + kLayout.foot_contacts.start + c;
      CHECK(out[at] == now[at]);
    }
  }
}

TEST_CASE("patch seams lose most of their jerk; the heading stays a unit vector", "[motion_filter]") {
  const size_t m = kLayout.feature_size, frames = 40;
  std::vector<float> in = ramp(frames, 0.02, 0.0);
  const size_t column = kLayout.root_position.start;
  for (size_t f = 0; f < frames; ++f) {
    in[f * m + column] += (f / 4) % 2 ? 0.03f : -0.03f;  // a jump every 4 frames
    const double psi = 0.05 * double(f) + ((f / 4) % 2 ? 0.1 : -0.1);
    in[f * m + kLayout.heading.start] = static_cast<float>(std::cos(psi));
    in[f * m + kLayout.heading.start + 1] = static_cast<float>(std::sin(psi));
  }
  const std::vector<float> out = ardy::smooth_features(kLayout, nullptr, 0, in.data(), frames, 1.5);
  CHECK(column_jerk(out, column) < 0.2 * column_jerk(in, column));
  for (size_t f = 0; f < frames; ++f) {
    const float c = out[f * m + kLayout.heading.start], s = out[f * m + kLayout.heading.start + 1];
    CHECK(std::hypot(c, s) == Approx(1.0f).margin(1e-5));
  }
}

TEST_CASE("a window follows on from its context without a step", "[motion_filter]") {
  // Context ends at 1.0, the new window starts at 1.6: the first frame
  // continues the context, the step is spread over the next ones.
  const size_t m = kLayout.feature_size;
  const std::vector<float> past = ramp(8, 0.0, 1.0);
  const std::vector<float> now = ramp(8, 0.0, 1.6);
  const std::vector<float> out = ardy::smooth_features(kLayout, past.data(), 8, now.data(), 8, 1.5);
  const size_t column = kLayout.root_position.start + 1;
  CHECK(out[column] == Approx(past[7 * m + column]).margin(1e-6));
  for (size_t f = 1; f < 8; ++f) {
    INFO("frame " << f);
    CHECK(out[f * m + column] - out[(f - 1) * m + column] < 0.35 * (now[column] - past[7 * m + column]));
  }
  CHECK(out[7 * m + column] == Approx(1.6 + 0.01 * column).margin(1e-3));
  // A moving context is continued at its speed.
  const std::vector<float> moving = ramp(8, 0.1, 1.0);
  const std::vector<float> joined = ardy::smooth_features(kLayout, moving.data(), 8, now.data(), 8, 1.5);
  CHECK(joined[column] == Approx(moving[7 * m + column] + 0.1).margin(1e-5));
  // A window that ends mid-turn keeps turning: the heading stays a unit vector.
  std::vector<float> turning = ramp(8, 0.0, 1.0);
  for (size_t f = 0; f < 8; ++f) {
    turning[f * m + kLayout.heading.start] = static_cast<float>(std::cos(0.3 * double(f)));
    turning[f * m + kLayout.heading.start + 1] = static_cast<float>(std::sin(0.3 * double(f)));
  }
  const std::vector<float> turned = ardy::smooth_features(kLayout, nullptr, 0, turning.data(), 8, 1.5);
  const float c = turned[7 * m + kLayout.heading.start], s = turned[7 * m + kLayout.heading.start + 1];
  CHECK(std::hypot(c, s) == Approx(1.0f).margin(1e-5));
  CHECK(std::atan2(s, c) == Approx(2.1).margin(0.05));
}

TEST_CASE("a joint's rotation is smoothed as a rotation: skewed 6D values do not swing the bone",
          "[motion_filter]") {
  // The default model's 6D of a right thigh over 11 frames of a wave (planner seed 18,
  // 2026-12-04): the first column short and leaning on the second, its sign flipping
  // between frames. The bone (the rotation's second axis, along the thigh) is within 24
  // degrees of its mean in every frame; filtering the raw values swung it 40 degrees off.
  const float thigh[11][6] = {
      {-0.00f, 0.05f, 0.38f, 0.01f, 1.06f, 0.14f},  {-0.18f, 0.09f, 0.20f, 0.12f, 1.13f, -0.02f},
      {-0.30f, 0.07f, 0.45f, 0.05f, 1.09f, -0.03f}, {-0.37f, 0.11f, 0.00f, -0.14f, 1.07f, -0.03f},
      {0.37f, 0.10f, -0.10f, -0.08f, 1.05f, 0.01f}, {0.40f, 0.11f, -0.04f, -0.04f, 1.04f, 0.00f},
      {0.40f, 0.12f, -0.03f, -0.05f, 1.03f, -0.01f}, {0.33f, 0.12f, -0.03f, -0.06f, 1.03f, 0.01f},
      {0.41f, 0.08f, -0.07f, -0.04f, 1.03f, 0.00f}, {0.42f, 0.10f, -0.02f, -0.02f, 1.03f, 0.00f},
      {0.42f, 0.10f, -0.02f, -0.02f, 1.03f, 0.01f}};
  const size_t m = kLayout.feature_size, frames = 11, joint = 3;
  std::vector<float> in = ramp(frames, 0.0, 0.0);
  for (size_t f = 0; f < frames; ++f) {
    for (size_t k = 0; k < 6; ++k) in[f * m + kLayout.rotation_6d.start + 6 * joint + k] = thigh[f][k];
  }
  const auto bone = [&](const std::vector<float>& x, size_t f) {
    return glm::normalize(ardy::model_rotation_from_6d(x.data() + f * m + kLayout.rotation_6d.start + 6 * joint)[1]);
  };
  glm::vec3 mean(0.0f);
  for (size_t f = 0; f < frames; ++f) mean += bone(in, f);
  mean = glm::normalize(mean);
  const auto degrees_off = [&](glm::vec3 axis) {
    return std::acos(std::clamp(double(glm::dot(axis, mean)), -1.0, 1.0)) * 180.0 / 3.14159265358979;
  };
  double raw_worst = 0.0;
  for (size_t f = 0; f < frames; ++f) raw_worst = std::max(raw_worst, degrees_off(bone(in, f)));
  REQUIRE(raw_worst < 24.0);
  const std::vector<float> out = ardy::smooth_features(kLayout, nullptr, 0, in.data(), frames, 1.5);
  for (size_t f = 0; f < frames; ++f) {
    INFO("frame " << f << ": the filtered bone is " << degrees_off(bone(out, f)) << " degrees off the mean");
    CHECK(degrees_off(bone(out, f)) <= raw_worst);
  }
}

TEST_CASE("a joint that flips half a turn between two frames turns over several frames", "[motion_filter]") {
  // The model sometimes turns a leg most of a half turn from one frame to the next. Averaged
  // as 6D values (or matrices) the columns that flip pass near zero and the filtered joint
  // still turns all at once (a toe at 23 m/s); as rotations the turn is spread.
  const size_t m = kLayout.feature_size, frames = 20, joint = 5;
  const double flip = 170.0 * 3.14159265358979 / 180.0;
  std::vector<float> in = ramp(frames, 0.0, 0.0);
  for (size_t f = 0; f < frames; ++f) {
    const double angle = f < frames / 2 ? 0.0 : flip;
    const float six[6] = {1.0f, 0.0f, 0.0f, 0.0f, float(std::cos(angle)), float(std::sin(angle))};
    std::copy(six, six + 6, in.begin() + static_cast<long>(f * m + kLayout.rotation_6d.start + 6 * joint));
  }
  const std::vector<float> out = ardy::smooth_features(kLayout, nullptr, 0, in.data(), frames, 1.5);
  const auto rotation = [&](size_t f) {
    return ardy::model_rotation_from_6d(out.data() + f * m + kLayout.rotation_6d.start + 6 * joint);
  };
  double largest_turn = 0.0, total_turn = 0.0;
  for (size_t f = 1; f < frames; ++f) {
    const glm::mat3 between = glm::transpose(rotation(f - 1)) * rotation(f);
    const double cosine = std::clamp((double(between[0][0] + between[1][1] + between[2][2]) - 1.0) / 2.0, -1.0, 1.0);
    largest_turn = std::max(largest_turn, std::acos(cosine));
    total_turn += std::acos(cosine);
  }
  INFO("largest turn between frames " << largest_turn << " rad of a " << flip << " rad flip");
  CHECK(total_turn == Approx(flip).margin(0.02));  // it turns the way the joint does, once
  CHECK(largest_turn < 0.4 * flip);
}
