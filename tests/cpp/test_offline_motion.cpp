// offline_motion: a whole timeline generated ahead of time by a Planner
// driven to the end. It must be what a streaming planner with the same config
// shows when nothing interrupts it (the game, the editor's bake and the CLI
// share this path), the same on every run, and the JSON timeline written for
// the CLI must read back as the same timeline.

#include <catch_amalgamated.hpp>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bvh.hpp"
#include "offline_motion.hpp"
#include "planner.hpp"
#include "support/error_message.hpp"
#include "support/goldens.hpp"
#include "timeline.hpp"

using ardy::Constraint;
using ardy::OfflineMotion;
using ardy::PlannerConfig;
using ardy::Pose;
using ardy_test::error_message;
using ardy_test::tiny_package;
using Catch::Matchers::ContainsSubstring;

namespace {

// Prompts at 0 and 1.3 s, a waypoint, a path, a joint target, a contact: every
// kind of goal a timeline sends.
ardy::Timeline sample_timeline(const ardy::ModelPackage& package) {
  return ardy::parse_timeline_text(R"({
    "prompts": [{"time": 0, "text": "a person walks forward"}, {"time": 1.3, "text": "a person waves"}],
    "constraints": [
      {"type": "waypoint", "time": 1.0, "x": 0.4, "z": 1.2, "heading": 0.3},
      {"type": "path", "start_time": 1.5, "points": [[0.4, 1.2], [1.0, 2.0]], "speed": 1.1},
      {"type": "joint", "time": 2.0, "joint": 0, "position": [0.9, 0.95, 1.9]},
      {"type": "contact", "start_time": 0.5, "end_time": 0.8, "feet": [0], "value": 0}]})",
                                   package, "sample");
}

PlannerConfig config_of(const ardy::Timeline& timeline) {
  PlannerConfig config;
  config.seed = 11;
  config.history_seconds = 2.0;
  config.initial_prompts = timeline.prompts;
  config.initial_constraints = timeline.constraints;
  return config;
}

double largest_difference(const Pose& a, const Pose& b) {
  double worst = glm::length(a.root_position - b.root_position);
  for (size_t j = 0; j < a.positions.size(); ++j) {
    worst = std::max<double>(worst, glm::length(a.positions[j] - b.positions[j]));
    worst = std::max<double>(worst, glm::length(glm::vec4(a.local_rotations[j].x - b.local_rotations[j].x,
                                                          a.local_rotations[j].y - b.local_rotations[j].y,
                                                          a.local_rotations[j].z - b.local_rotations[j].z,
                                                          a.local_rotations[j].w - b.local_rotations[j].w)));
  }
  return worst;
}

}  // namespace

TEST_CASE("offline motion is what a streaming planner shows, the same on every run", "[offline]") {
  const auto package = tiny_package();
  const ardy::Timeline timeline = sample_timeline(*package);
  const OfflineMotion first = ardy::generate_offline(package, config_of(timeline), 3.0);
  const OfflineMotion second = ardy::generate_offline(package, config_of(timeline), 3.0);
  REQUIRE(first.frames.size() == static_cast<size_t>(std::llround(3.0 * package->fps())));
  REQUIRE(second.frames.size() == first.frames.size());
  double across_runs = 0.0;
  for (size_t f = 0; f < first.frames.size(); ++f) {
    across_runs = std::max(across_runs, largest_difference(first.frames[f], second.frames[f]));
  }
  CHECK(across_runs <= 1e-5);
  // A window is cut where the second prompt starts (1.3 s -> frame 26, token boundary 28).
  bool cut_at_prompt = false;
  for (const ardy::WindowRecord& window : first.windows) {
    cut_at_prompt |= window.start_frame == 28 && window.prompt == std::string("a person waves");
  }
  CHECK(cut_at_prompt);

  // A game's planner: the same config, played in real time at 60 Hz.
  ardy::Planner planner(package, config_of(timeline));
  Pose pose;
  std::vector<Pose> shown(first.frames.size());
  std::vector<bool> seen(first.frames.size(), false);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  size_t next = 0;
  while (next < shown.size() && std::chrono::steady_clock::now() < deadline) {
    for (size_t f = next; f < shown.size() && planner.frame_at(static_cast<int64_t>(f), pose); ++f) {
      if (!seen[f]) shown[f] = pose, seen[f] = true;
    }
    while (next < shown.size() && seen[next]) ++next;
    std::this_thread::sleep_for(std::chrono::milliseconds(4));
    planner.advance(1.0 / 60.0);
  }
  REQUIRE(next == shown.size());
  CHECK(planner.stats().splices == 0);
  double against_planner = 0.0;
  for (size_t f = 0; f < shown.size(); ++f) {
    against_planner = std::max(against_planner, largest_difference(first.frames[f], shown[f]));
  }
  INFO("largest difference to the streaming planner: " << against_planner);
  CHECK(against_planner <= 1e-5);

  // The BVH writer: one line per frame after the header.
  const std::string bvh = ardy::motion_to_bvh(package->skeleton(), package->fps(), first.frames);
  CHECK_THAT(bvh, ContainsSubstring("Frames: " + std::to_string(first.frames.size()) + "\n"));
}

TEST_CASE("sample_offline interpolates between frames and clamps to the motion", "[offline]") {
  const auto package = tiny_package();
  const OfflineMotion motion = ardy::generate_offline(package, config_of(sample_timeline(*package)), 1.0);
  Pose pose;
  REQUIRE(ardy::sample_offline(motion, 0.5 / package->fps() + 0.2, pose));
  const Pose& a = motion.frames[4];
  const Pose& b = motion.frames[5];
  CHECK(glm::length(pose.root_position - 0.5f * (a.root_position + b.root_position)) < 1e-5f);
  REQUIRE(ardy::sample_offline(motion, 99.0, pose));
  CHECK(pose.root_position == motion.frames.back().root_position);
  CHECK_FALSE(ardy::sample_offline(OfflineMotion{}, 0.0, pose));
}

TEST_CASE("offline motion refuses bad lengths and reports a failing window", "[offline][errors]") {
  const auto package = tiny_package();
  CHECK_THAT(error_message([&] { ardy::generate_offline(package, {}, 0.0); }), ContainsSubstring("seconds is 0"));
  CHECK_THAT(error_message([&] { ardy::generate_offline(package, {}, 5000.0); }), ContainsSubstring("at most 3600"));
  PlannerConfig failing;
  failing.generator = [](const std::shared_ptr<const ardy::ModelPackage>&, const ardy::WindowInput&,
                         const std::vector<float>&, const ardy::CancelCheck&) -> ardy::WindowResult {
    throw ardy::Error("the model double fails");
  };
  CHECK_THAT(error_message([&] { ardy::generate_offline(package, failing, 1.0); }),
             ContainsSubstring("the model double fails"));
  PlannerConfig bad;
  bad.initial_constraints.push_back(ardy::RootWaypoint{10, std::nan(""), 0.0, std::nullopt});
  CHECK_THAT(error_message([&] { ardy::generate_offline(package, bad, 1.0); }),
             ContainsSubstring("initial_constraints[0]"));
  std::vector<double> told;
  CHECK_THAT(error_message([&] {
               ardy::generate_offline(package, {}, 20.0, [&](double fraction) {
                 told.push_back(fraction);
                 return false;
               });
             }),
             ContainsSubstring("cancelled"));
  REQUIRE(told.size() == 1);
  CHECK(told[0] > 0.0);
  CHECK(told[0] < 1.0);
}

TEST_CASE("timeline_to_json reads back as the same timeline", "[offline][timeline]") {
  const auto package = tiny_package();
  ardy::Timeline timeline = sample_timeline(*package);
  timeline.prompts.push_back({50, std::nullopt});
  ardy::JointTarget turned;
  turned.frame = 12;
  turned.joint = 3;
  turned.rotation = glm::dmat3(glm::dvec3(0, 0, 1), glm::dvec3(0, 1, 0), glm::dvec3(-1, 0, 0));
  timeline.constraints.push_back(turned);
  ardy::PoseKeyframe keyframe;
  keyframe.frame = 30;
  keyframe.features.assign(package->layout().feature_size, 0.25);
  keyframe.include_root = false;
  timeline.constraints.push_back(keyframe);
  const ardy::Timeline back =
      ardy::parse_timeline_text(ardy::timeline_to_json(timeline, *package).dump(), *package, "written");
  REQUIRE(back.prompts.size() == timeline.prompts.size());
  for (size_t i = 0; i < back.prompts.size(); ++i) {
    CHECK(back.prompts[i].frame == timeline.prompts[i].frame);
    CHECK(back.prompts[i].text == timeline.prompts[i].text);
  }
  REQUIRE(back.constraints.size() == timeline.constraints.size());
  for (size_t i = 0; i < back.constraints.size(); ++i) {
    CHECK(std::string(ardy::constraint_type_name(back.constraints[i])) ==
          ardy::constraint_type_name(timeline.constraints[i]));
  }
  // Field by field where it matters, then everything through the writer.
  const auto& waypoint = std::get<ardy::RootWaypoint>(back.constraints[0]);
  CHECK(waypoint.frame == 20);
  CHECK(waypoint.x == 0.4);
  CHECK(waypoint.heading == 0.3);
  const auto& path = std::get<ardy::RootPath>(back.constraints[1]);
  const auto& original_path = std::get<ardy::RootPath>(timeline.constraints[1]);
  CHECK(path.positions == original_path.positions);
  CHECK(path.headings == original_path.headings);
  CHECK(std::get<ardy::FootContact>(back.constraints[3]).feet == std::vector<size_t>{0});
  CHECK(std::get<ardy::FootContact>(back.constraints[3]).value == 0.0);
  CHECK(*std::get<ardy::JointTarget>(back.constraints[4]).rotation == *turned.rotation);
  CHECK(std::get<ardy::PoseKeyframe>(back.constraints[5]).features == keyframe.features);
  CHECK_FALSE(std::get<ardy::PoseKeyframe>(back.constraints[5]).include_root);
  CHECK(ardy::timeline_to_json(back, *package) == ardy::timeline_to_json(timeline, *package));
}
