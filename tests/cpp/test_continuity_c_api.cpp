// No pops through the C ABI (issue 15 item 5): the session where the pop was
// seen (ardy_c.h at 60 Hz, run -> wave prompt changes) checked like
// test_continuity.cpp (support/continuity.hpp). The C ABI has no raw-frame
// accessor, so the model's own frames come from a second planner of the same
// model, seed and commands with the output filter and foot lock off: both
// only change what is shown, never the history the model reads, so its
// windows are the same (checked: the same window shows every frame, and the
// same windows were made). The replan buffer is fixed (min_buffer_frames
// above any measured latency) so both planners splice at the same frames.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <string>
#include <vector>

#include "ardy_c.h"
#include "support/continuity.hpp"

using ardy_test::ContinuitySession;

namespace {

struct Model {
  ardy_model* model = nullptr;
  Model() {
    ardy_model_params params = ardy_model_default_params();
    params.intra_op_threads = 1;
    REQUIRE(ardy_model_load_from_folder(ARDY_SHIPPED_MODEL_DIR, &params, &model) == ARDY_OK);
  }
  ~Model() { ardy_model_free(model); }
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;
};

struct PlannerHandle {
  ardy_planner* planner = nullptr;
  PlannerHandle(ardy_model* model, bool shown) {
    ardy_planner_params params = ardy_planner_default_params();
    params.seed = 15;
    params.min_buffer_frames = 24;  // 1.2 s: above any window's latency here, so B is this
    params.low_water_seconds = 3.0;
    if (!shown) {
      params.output_smoothing_frames = 0.0;
      params.foot_lock = false;
    }
    REQUIRE(ardy_planner_create(model, &params, &planner) == ARDY_OK);
  }
  ~PlannerHandle() { ardy_planner_free(planner); }
  PlannerHandle(const PlannerHandle&) = delete;
  PlannerHandle& operator=(const PlannerHandle&) = delete;
};

}  // namespace

TEST_CASE("no joint moves faster than the model's own motion through the C ABI at 60 Hz (run -> wave)",
          "[continuity][c_api]") {
  const Model model;
  PlannerHandle shown(model.model, true), raw(model.model, false);
  const size_t joints = ardy_model_joint_count(model.model);
  ContinuitySession session;
  session.model_fps = ardy_model_fps(model.model);
  for (size_t j = 0; j < joints; ++j) session.joint_names.emplace_back(ardy_model_joint_name(model.model, j));

  struct Prompt {
    double time;
    const char* text;
  };
  const std::vector<Prompt> script = {
      {1.0, "a person walks forward"},  {3.0, "a person runs forward"},
      {6.0, "a person waves with the right hand"}, {8.5, "a person runs forward"},
      {11.0, "a person waves with the right hand"}, {13.5, "a person runs forward"},
      {16.0, "a person waves with the right hand"},
  };
  const double seconds = 20.0;
  const auto both_idle = [&] {
    REQUIRE(ardy_planner_wait_idle(shown.planner, 600.0) == ARDY_OK);
    REQUIRE(ardy_planner_wait_idle(raw.planner, 600.0) == ARDY_OK);
  };
  both_idle();
  std::vector<float> positions(joints * 3);
  size_t next = 0, window_mismatches = 0;
  ardy_pose_info info{}, raw_info{};
  const auto steps = static_cast<size_t>(seconds * ardy_test::kShownRate);
  for (size_t n = 0; n <= steps; ++n) {
    if (n > 0) {
      REQUIRE(ardy_planner_advance(shown.planner, 1.0 / ardy_test::kShownRate) == ARDY_OK);
      REQUIRE(ardy_planner_advance(raw.planner, 1.0 / ardy_test::kShownRate) == ARDY_OK);
    }
    both_idle();
    const double t = double(n) / ardy_test::kShownRate;
    REQUIRE(ardy_planner_sample(shown.planner, t, &info, nullptr, positions.data(), nullptr, joints, 0) == ARDY_OK);
    std::vector<glm::vec3>& pose = session.shown.emplace_back(joints);
    for (size_t j = 0; j < joints; ++j) pose[j] = glm::vec3(positions[3 * j], positions[3 * j + 1], positions[3 * j + 2]);
    // The raw planner's model frames up to the playhead's + 1 (final: a splice starts after them).
    const auto final_frame = static_cast<int64_t>(std::floor(t * session.model_fps)) + 1;
    while (static_cast<int64_t>(session.raw.size()) <= final_frame) {
      const double frame_time = double(session.raw.size()) / session.model_fps;
      REQUIRE(ardy_planner_sample(raw.planner, frame_time, &raw_info, nullptr, positions.data(), nullptr, joints, 0) ==
              ARDY_OK);
      REQUIRE(ardy_planner_sample(shown.planner, frame_time, &info, nullptr, nullptr, nullptr, joints, 0) == ARDY_OK);
      if (raw_info.window_id != info.window_id) ++window_mismatches;
      std::vector<glm::vec3>& frame = session.raw.emplace_back(joints);
      for (size_t j = 0; j < joints; ++j) {
        frame[j] = glm::vec3(positions[3 * j], positions[3 * j + 1], positions[3 * j + 2]);
      }
    }
    if (next < script.size() && t >= script[next].time) {
      REQUIRE(ardy_planner_set_prompt(shown.planner, script[next].text) == ARDY_OK);
      REQUIRE(ardy_planner_set_prompt(raw.planner, script[next].text) == ARDY_OK);
      session.events.push_back({t, std::string("prompt: ") + script[next].text});
      both_idle();
      ++next;
    }
  }
  ardy_planner_stats a{}, b{};
  REQUIRE(ardy_planner_get_stats(shown.planner, &a) == ARDY_OK);
  REQUIRE(ardy_planner_get_stats(raw.planner, &b) == ARDY_OK);
  std::cout << "continuity session (C ABI): " << seconds << " s, " << a.windows_published << " windows (" << a.splices
            << " splices, " << a.late_windows << " late), buffer " << a.buffer_frames << " frames, underrun "
            << a.underrun_seconds << " s\n";
  // The raw planner made the same windows (else its frames are not the shown ones' model output).
  REQUIRE(window_mismatches == 0);
  REQUIRE(a.windows_published == b.windows_published);
  REQUIRE(a.splices == b.splices);
  CHECK(a.underrun_seconds == 0.0);

  const ardy_test::ContinuityReport report = ardy_test::check_continuity(session);
  std::cout << "continuity (C ABI): " << report.text;
  CHECK(double(report.steps) >= 0.95 * seconds * ardy_test::kShownRate);
  CHECK(report.failures == 0);
  CHECK(report.fastest.shown <= ardy_test::kMaxJointSpeed);
}
