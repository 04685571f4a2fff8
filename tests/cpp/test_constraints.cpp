// Constraints: validation, path helpers (polyline, clicks, keyboard
// velocity), the timeline, the per-window goal tensors (constraints.py) on
// hand-computed cases and on the goldens, and the JSON timeline schema.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "constraints.hpp"
#include "support/error_message.hpp"
#include "support/goldens.hpp"
#include "support/skeletons.hpp"
#include "timeline.hpp"

using ardy::Constraint;
using ardy::ConstraintTimeline;
using ardy::FeatureLayout;
using ardy::FootContact;
using ardy::JointTarget;
using ardy::PoseKeyframe;
using ardy::RootPath;
using ardy::RootWaypoint;
using ardy::WindowGoals;
using ardy_test::error_message;
using ardy_test::goldens;
using ardy_test::tiny_package;
using Catch::Matchers::ContainsSubstring;
using Catch::Matchers::WithinAbs;
using nlohmann::json;

namespace {

const FeatureLayout& layout() {
  static const FeatureLayout l = FeatureLayout::ardy_default(21, 4);
  return l;
}

// Statistics with mean 0 and std 1 except where a test sets them.
ardy::Normalization unit_stats(size_t m = 258) {
  return ardy::Normalization(std::vector<float>(m, 0.0f), std::vector<float>(m, 1.0f));
}

ardy::GoalSpec spec(const ardy::Normalization& norm, size_t window = 10, size_t future = 4, size_t patch = 4) {
  ardy::GoalSpec s;
  s.layout = &layout();
  s.normalization = &norm;
  s.patch = patch;
  s.window_tokens = window;
  s.future_limit_tokens = future;
  return s;
}

// Goal entry of frame f (relative to the window start) and feature i.
float goal_at(const WindowGoals& g, size_t frame, size_t feature, bool mask = false) {
  const size_t m = layout().feature_size, patch = g.goal_dim / m;
  const size_t token = frame / patch, p = frame % patch;
  if (token < g.window_tokens) {
    return (mask ? g.window_goal_mask : g.window_goal)[token * g.goal_dim + p * m + feature];
  }
  const size_t k = token - g.window_tokens;
  return (mask ? g.future_goal_mask : g.future_goal)[k * g.goal_dim + p * m + feature];
}

size_t count_mask(const std::vector<float>& mask) {
  size_t n = 0;
  for (float v : mask) n += v != 0.0f;
  return n;
}

}  // namespace

// --- validation ------------------------------------------------------------------------------

TEST_CASE("NaN and infinity are refused with the constraint and the field named", "[constraints][errors]") {
  const auto message = [](const Constraint& c) {
    return error_message([&] { ardy::validate_constraint(c, layout(), "constraints[2]"); });
  };
  RootWaypoint w;
  w.heading = INFINITY;
  CHECK(message(w) == "constraints[2] (RootWaypoint): heading is +infinity (values must be finite)");
  w.heading.reset();
  w.z = -INFINITY;
  CHECK_THAT(message(w), ContainsSubstring("z is -infinity"));
  RootPath path;
  path.positions = {{0, 0}, {1, std::nan("")}};
  CHECK_THAT(message(path), ContainsSubstring("constraints[2] (RootPath): positions[1].z is NaN"));
  path.positions = {{0, 0}, {1, 1}};
  path.headings = {0.0};
  CHECK_THAT(message(path), ContainsSubstring("headings has 1 entries, expected one per position (2) or none"));
  path.headings = {0.0, std::nan("")};
  CHECK_THAT(message(path), ContainsSubstring("headings[1] is NaN"));
  CHECK_THAT(message(RootPath{}), ContainsSubstring("positions is empty"));
  PoseKeyframe key;
  key.features.assign(258, 0.0);
  key.features[100] = std::nan("");
  CHECK_THAT(message(key), ContainsSubstring("(PoseKeyframe): features[100] is NaN"));
  key.features.assign(257, 0.0);
  CHECK_THAT(message(key), ContainsSubstring("features has 257 values, expected 258"));
  JointTarget joint;
  joint.joint = 12;
  joint.position = glm::dvec3(0.0, std::nan(""), 0.0);
  CHECK_THAT(message(joint), ContainsSubstring("(JointTarget): position.y is NaN"));
  joint.position.reset();
  CHECK_THAT(message(joint), ContainsSubstring("has neither a position nor a rotation"));
  glm::dmat3 rot(1.0);
  rot[2][1] = INFINITY;
  joint.rotation = rot;
  CHECK_THAT(message(joint), ContainsSubstring("rotation[1][2] is +infinity"));
  joint.rotation = glm::dmat3(1.0);
  joint.joint = 21;
  CHECK_THAT(message(joint), ContainsSubstring("joint 21 is out of range (the skeleton has joints 0..20)"));
  FootContact contact;
  contact.start_frame = 5;
  contact.end_frame = 5;
  CHECK_THAT(message(contact), ContainsSubstring("end_frame 5 must be greater than start_frame 5"));
  contact.end_frame = 9;
  contact.feet = {0, 4};
  CHECK_THAT(message(contact), ContainsSubstring("feet[1] is 4"));
  contact.feet = {0};
  contact.value = std::nan("");
  CHECK_THAT(message(contact), ContainsSubstring("value is NaN"));
}

TEST_CASE("unknown joint names are named with the valid ones", "[constraints][errors]") {
  const ardy::Skeleton skeleton = ardy_test::ardy_test_skeleton();
  CHECK(ardy::joint_index(skeleton, "Hand_R") == 12);
  CHECK_THAT(error_message([&] { ardy::joint_index(skeleton, "RightHand"); }),
             ContainsSubstring("unknown joint 'RightHand' (the skeleton's joints are Hips, Spine, Chest") &&
                 ContainsSubstring("Toes_R)"));
}

// --- path helpers -------------------------------------------------------------------------------

TEST_CASE("path_from_polyline samples the polyline at constant speed (constraints.py)", "[constraints][paths]") {
  const RootPath straight = ardy::path_from_polyline({{0, 0}, {0, 5}}, 1.2, 7, 20.0);
  CHECK(straight.start_frame == 7);
  REQUIRE(straight.positions.size() == 84);  // floor(5 / 1.2 * 20) + 1
  CHECK_THAT(straight.positions[10].y, WithinAbs(0.6, 1e-12));
  CHECK(straight.positions[10].x == 0.0);
  REQUIRE(straight.headings.size() == 84);
  CHECK(straight.headings[0] == 0.0);

  const RootPath corner = ardy::path_from_polyline({{0, 0}, {1, 0}, {1, 1}}, 1.0, 0, 10.0);
  REQUIRE(corner.positions.size() == 21);
  CHECK(corner.positions[10] == glm::dvec2(1.0, 0.0));  // exactly on the corner point
  CHECK_THAT(corner.positions[15].y, WithinAbs(0.5, 1e-12));
  CHECK_THAT(corner.headings[5], WithinAbs(M_PI / 2, 1e-12));  // along +X
  CHECK(corner.headings[10] == 0.0);                           // the second segment from the corner on
  CHECK(ardy::path_from_polyline({{0, 0}, {1, 0}}, 1.0, 0, 10.0, false).headings.empty());

  CHECK_THAT(error_message([] { ardy::path_from_polyline({{0, 0}}, 1.0, 0, 20.0); }),
             ContainsSubstring("at least 2 points"));
  CHECK_THAT(error_message([] { ardy::path_from_polyline({{0, 0}, {1, 1}}, 0.0, 0, 20.0); }),
             ContainsSubstring("speed is 0"));
  CHECK_THAT(error_message([] { ardy::path_from_polyline({{0, 0}, {5e5, 0}}, 1.0, 0, 20.0); }),
             ContainsSubstring("more than the"));
}

TEST_CASE("numbers that parse but are no motion are refused with the bound", "[constraints][errors]") {
  const auto message = [&](const Constraint& c) {
    return error_message([&] { ardy::validate_constraint(c, layout(), "constraints[0]"); });
  };
  RootWaypoint waypoint;
  waypoint.x = 1e300;
  CHECK_THAT(message(waypoint), ContainsSubstring("constraints[0] (RootWaypoint): x is 1e+300, outside +-1e+06 m "
                                                  "(positions must lie within 1e6 m of the origin)"));
  waypoint.x = -1e6;  // the bound itself is fine
  waypoint.z = 2e6;
  CHECK_THAT(message(waypoint), ContainsSubstring("z is 2e+06, outside +-1e+06 m"));
  waypoint.z = 0.0;
  waypoint.heading = 1e20;
  CHECK_THAT(message(waypoint), ContainsSubstring("heading is 1e+20, outside +-1e+06 rad"));
  RootPath path;
  path.positions = {{0.0, 0.0}, {0.0, -3e7}};
  CHECK_THAT(message(path), ContainsSubstring("(RootPath): positions[1].z is -3e+07, outside +-1e+06 m"));
  JointTarget joint;
  joint.joint = 3;
  joint.position = glm::dvec3(0.0, 1e9, 0.0);
  CHECK_THAT(message(joint), ContainsSubstring("(JointTarget): position.y is 1e+09, outside +-1e+06 m"));
  PoseKeyframe key;
  key.features.assign(layout().feature_size, 0.0);
  key.features[7] = -1e12;
  CHECK_THAT(message(key), ContainsSubstring("(PoseKeyframe): features[7] is -1e+12, outside +-1e+06"));
  FootContact contact;
  contact.end_frame = 4;
  contact.value = 2.0;
  CHECK_THAT(message(contact), ContainsSubstring("(FootContact): value is 2, expected 0 (free) .. 1 (planted)"));

  CHECK_THAT(error_message([] { ardy::path_from_polyline({{0, 0}, {1, 0}}, 1e30, 0, 20.0); }),
             ContainsSubstring("path_from_polyline: speed is 1e+30, expected a positive finite speed up to 100 m/s"));
  CHECK_THAT(error_message([] { ardy::path_from_clicks({{0, 0}, {1e300, 0}}, 1.0, 0, 20.0); }),
             ContainsSubstring("path_from_clicks: points[1] is (1e+300, 0), outside +-1e6 m"));
  CHECK(ardy::path_from_polyline({{0, 0}, {1, 0}}, 100.0, 0, 20.0).positions.size() == 1);
}

TEST_CASE("mouse clicks become a smoothed dense path through the first and last click", "[constraints][paths]") {
  const std::vector<glm::dvec2> clicks{{0, 0}, {2, 0}, {2, 2}};
  const RootPath path = ardy::path_from_clicks(clicks, 1.0, 3, 20.0, 6);
  const RootPath linear = ardy::path_from_polyline(clicks, 1.0, 3, 20.0, false);
  REQUIRE(path.positions.size() == linear.positions.size());
  CHECK(path.positions.front() == clicks.front());
  CHECK(path.positions.back() == clicks.back());
  // The corner is cut: the frame at the corner lies inside the turn.
  const glm::dvec2 corner = path.positions[40];
  CHECK(linear.positions[40] == glm::dvec2(2.0, 0.0));
  CHECK(corner.x < 2.0);
  CHECK(corner.y > 0.0);
  REQUIRE(path.headings.size() == path.positions.size());
  CHECK_THAT(path.headings.front(), WithinAbs(M_PI / 2, 1e-9));
  CHECK_THAT(path.headings.back(), WithinAbs(0.0, 1e-9));
  // Headings turn monotonically from +X to +Z around the corner.
  for (size_t i = 1; i < path.headings.size(); ++i) CHECK(path.headings[i] <= path.headings[i - 1] + 1e-12);
  // A straight line stays straight.
  const RootPath line = ardy::path_from_clicks({{0, 0}, {0, 3}}, 1.5, 0, 20.0, 4);
  for (const glm::dvec2& p : line.positions) CHECK(p.x == 0.0);
}

TEST_CASE("keyboard velocity blends to the target over the window and integrates", "[constraints][paths]") {
  // Already at the target: constant velocity.
  const RootPath cruise = ardy::path_from_velocity({1.0, 2.0}, {1.0, 0.0}, {1.0, 0.0}, 40, 40, 10, 20.0);
  REQUIRE(cruise.positions.size() == 40);
  CHECK(cruise.start_frame == 40);
  CHECK_THAT(cruise.positions[0].x, WithinAbs(1.05, 1e-12));
  CHECK_THAT(cruise.positions[39].x, WithinAbs(3.0, 1e-12));
  CHECK(cruise.positions[39].y == 2.0);
  for (double h : cruise.headings) CHECK_THAT(h, WithinAbs(M_PI / 2, 1e-12));

  // From standing to 2 m/s along +Z over 10 frames, then constant.
  const RootPath start = ardy::path_from_velocity({0, 0}, {0, 0}, {0, 2.0}, 0, 20, 10, 20.0);
  double z = 0.0;
  for (size_t k = 0; k < 20; ++k) {
    z += 2.0 * std::min(1.0, double(k + 1) / 10.0) / 20.0;
    CHECK_THAT(start.positions[k].y, WithinAbs(z, 1e-12));
  }
  const double last_step = start.positions[19].y - start.positions[18].y;
  CHECK_THAT(last_step * 20.0, WithinAbs(2.0, 1e-9));
  for (double h : start.headings) CHECK_THAT(h, WithinAbs(0.0, 1e-12));

  // Stopping keeps the heading of travel; standing still has none unless given.
  const RootPath stop = ardy::path_from_velocity({0, 0}, {-1.0, 0}, {0, 0}, 0, 20, 10, 20.0);
  for (double h : stop.headings) CHECK_THAT(h, WithinAbs(-M_PI / 2, 1e-12));
  CHECK(ardy::path_from_velocity({0, 0}, {0, 0}, {0, 0}, 0, 10, 5, 20.0).headings.empty());
  const RootPath still = ardy::path_from_velocity({0, 0}, {0, 0}, {0, 0}, 0, 10, 5, 20.0, 1.25);
  for (double h : still.headings) CHECK(h == 1.25);
  CHECK_THAT(error_message([] { ardy::path_from_velocity({0, 0}, {NAN, 0}, {0, 0}, 0, 10, 5, 20.0); }),
             ContainsSubstring("current_velocity is not finite"));
}

// --- timeline ----------------------------------------------------------------------------------------

TEST_CASE("the constraint timeline validates, removes, drops passed ones and splits by time", "[constraints]") {
  ConstraintTimeline timeline(layout());
  const auto a = timeline.add(RootWaypoint{10, 1.0, 2.0, std::nullopt});
  RootPath path;
  path.start_frame = 30;
  path.positions.assign(20, glm::dvec2(0.0));
  const auto b = timeline.add(path);  // frames 30..49
  const auto c = timeline.add(FootContact{100, 120, {0}, 1.0});
  const uint64_t revision = timeline.revision();
  RootWaypoint bad{5, std::nan(""), 0.0, std::nullopt};
  CHECK_THAT(error_message([&] { timeline.add(bad); }), ContainsSubstring("constraint (RootWaypoint): x is NaN"));
  CHECK(timeline.size() == 3);
  CHECK(timeline.revision() == revision);

  const auto split = timeline.split(40, 56);  // frames [40, 96)
  CHECK(split.passed == std::vector<ConstraintTimeline::Id>{a});
  CHECK(split.active == std::vector<ConstraintTimeline::Id>{b});
  CHECK(split.waiting == std::vector<ConstraintTimeline::Id>{c});
  CHECK(timeline.drop_passed(50) == std::vector<ConstraintTimeline::Id>{a, b});
  CHECK(timeline.size() == 1);
  CHECK(timeline.find(c) != nullptr);
  CHECK(timeline.revision() != revision);
  CHECK(timeline.remove(c));
  CHECK(!timeline.remove(c));
  CHECK(timeline.empty());
}

// --- window goals ----------------------------------------------------------------------------------------

TEST_CASE("window goals: re-centred, normalized, patchified, later constraints override", "[constraints][goals]") {
  std::vector<float> mean(258, 0.0f), stddev(258, 1.0f);
  mean[0] = 0.5f;
  stddev[0] = 2.0f;
  mean[254] = 0.5f;
  stddev[254] = 0.5f;
  const ardy::Normalization norm(mean, stddev);
  std::vector<Constraint> constraints;
  constraints.push_back(RootWaypoint{45, 3.0, 4.0, 0.5});           // in the window (start 40)
  constraints.push_back(RootWaypoint{45, 5.0, 6.0, std::nullopt});  // overrides x and z, keeps the heading
  constraints.push_back(FootContact{50, 52, {0}, 0.0});
  JointTarget hand;
  hand.frame = 47;
  hand.joint = 12;
  hand.position = glm::dvec3(0.1, 1.2, 0.3);
  constraints.push_back(hand);
  constraints.push_back(RootWaypoint{85, 1.0, 1.0, std::nullopt});  // future token 1 (frames 84..87)
  constraints.push_back(RootWaypoint{96, 9.0, 9.0, std::nullopt});  // at the horizon: waits
  constraints.push_back(RootWaypoint{39, 9.0, 9.0, std::nullopt});  // passed
  const WindowGoals g = ardy::window_goals(constraints, 40, {1.0, -1.0}, spec(norm));

  CHECK(g.window_tokens == 10);
  CHECK(g.goal_dim == 1032);
  REQUIRE(g.future_tokens == 2);  // cut after the last constrained future token
  CHECK(g.future_mask == std::vector<float>{0.0f, 1.0f});
  CHECK(g.has_constraints());
  CHECK(goal_at(g, 5, 0) == float(((5.0 - 1.0) - 0.5) / 2.0));  // x: re-centred, normalized
  CHECK(goal_at(g, 5, 2) == float(6.0 + 1.0));                  // z
  CHECK(goal_at(g, 5, 3) == float(std::cos(0.5)));
  CHECK(goal_at(g, 5, 4) == float(std::sin(0.5)));
  CHECK(goal_at(g, 5, 1, true) == 0.0f);  // height not constrained
  CHECK(goal_at(g, 10, 254) == -1.0f);    // contact 0 -> (0 - 0.5) / 0.5
  CHECK(goal_at(g, 11, 254, true) == 1.0f);
  CHECK(goal_at(g, 12, 254, true) == 0.0f);  // end frame exclusive
  CHECK(goal_at(g, 11, 255, true) == 0.0f);  // only foot 0
  const size_t hand_at = layout().joint_position_of(12).start;
  CHECK(goal_at(g, 7, hand_at) == 0.1f);  // not re-centred: relative to the root
  CHECK(goal_at(g, 7, hand_at + 1) == 1.2f);
  CHECK(goal_at(g, 45, 0) == float(((1.0 - 1.0) - 0.5) / 2.0));
  // Exactly the constrained entries are set: 4 root + 2 contact frames + 3
  // hand in the window, 2 in the future.
  CHECK(count_mask(g.window_goal_mask) == 9);
  CHECK(count_mask(g.future_goal_mask) == 2);
  for (size_t i = 0; i < g.window_goal.size(); ++i) {
    if (g.window_goal_mask[i] == 0.0f) REQUIRE(g.window_goal[i] == 0.0f);
  }

  // Nothing constrained: no future tokens, no constraints.
  const WindowGoals none = ardy::window_goals(std::vector<Constraint>{}, 0, {0, 0}, spec(norm));
  CHECK(none.future_tokens == 0);
  CHECK(!none.has_constraints());
  // Only a future goal still counts as constrained.
  const WindowGoals future_only =
      ardy::window_goals(std::vector<Constraint>{RootWaypoint{50, 0, 0, std::nullopt}}, 0, {0, 0}, spec(norm));
  CHECK(!future_only.any_window_constraint);
  CHECK(future_only.has_constraints());
  CHECK(future_only.future_tokens == 3);
}

TEST_CASE("window goals: interpolate_root turns sparse root targets into a path from the character",
          "[constraints][goals]") {
  const ardy::Normalization norm = unit_stats();
  ardy::GoalSpec s = spec(norm);
  s.interpolate_root = true;
  std::vector<Constraint> constraints;
  constraints.push_back(RootWaypoint{49, 3.0, 4.0, 0.5});  // frame 9 of the window (start 40)
  constraints.push_back(RootWaypoint{59, 5.0, 4.0, std::nullopt});
  constraints.push_back(FootContact{42, 44, {0}, 1.0});
  const glm::dvec2 anchor{1.0, 2.0};  // the root of frame 39
  const WindowGoals g = ardy::window_goals(constraints, 40, anchor, s);
  // From the anchor (frame -1) to the first waypoint over 10 frames, re-centred on the anchor.
  for (size_t f = 0; f <= 9; ++f) {
    INFO("frame " << f);
    const double a = double(f + 1) / 10.0;
    CHECK_THAT(goal_at(g, f, 0), WithinAbs((1.0 + a * 2.0) - 1.0, 1e-6));
    CHECK_THAT(goal_at(g, f, 2), WithinAbs((2.0 + a * 2.0) - 2.0, 1e-6));
    CHECK(goal_at(g, f, 0, true) == 1.0f);
    CHECK(goal_at(g, f, 1, true) == 0.0f);  // height stays free
  }
  CHECK(goal_at(g, 9, 3, true) == 1.0f);  // the waypoint's heading, only at its frame
  CHECK(goal_at(g, 8, 3, true) == 0.0f);
  // Then between the two waypoints.
  CHECK_THAT(goal_at(g, 14, 0), WithinAbs(4.0 - 1.0, 1e-6));
  CHECK_THAT(goal_at(g, 14, 2), WithinAbs(4.0 - 2.0, 1e-6));
  // Nothing after the last target; other features untouched.
  CHECK(goal_at(g, 20, 0, true) == 0.0f);
  CHECK(count_mask(g.window_goal_mask) == 20 * 2 + 2 + 2);  // x, z of frames 0..19, heading, contacts
  // Off (the default): only the targets' own frames.
  const WindowGoals sparse = ardy::window_goals(constraints, 40, anchor, spec(norm));
  CHECK(goal_at(sparse, 5, 0, true) == 0.0f);
  CHECK(count_mask(sparse.window_goal_mask) == 2 + 2 + 2 + 2);
}

TEST_CASE("window goals: root_path_only marks a dense root path with nothing else constrained",
          "[constraints][goals]") {
  const ardy::Normalization norm = unit_stats();
  const ardy::GoalSpec s = spec(norm);  // 10 tokens of 4: 40 window frames from frame 40
  const auto path = [](int64_t start, size_t frames) {
    RootPath p;
    p.start_frame = start;
    for (size_t f = 0; f < frames; ++f) p.positions.push_back({0.01 * double(f), 0.0});
    return p;
  };
  const glm::dvec2 anchor{0.0, 0.0};
  // The whole window, and half of it (the bound), with headings into the future: a path.
  RootPath with_headings = path(40, 50);
  with_headings.headings.assign(50, 0.5);
  CHECK(ardy::window_goals(std::vector<Constraint>{with_headings}, 40, anchor, s).root_path_only);
  CHECK(ardy::window_goals(std::vector<Constraint>{path(60, 20)}, 40, anchor, s).root_path_only);
  // Less than half of the window, or only sparse waypoints: guidance as for any goal.
  CHECK(!ardy::window_goals(std::vector<Constraint>{path(61, 19)}, 40, anchor, s).root_path_only);
  const std::vector<Constraint> waypoints{RootWaypoint{49, 3.0, 4.0, 0.5}, RootWaypoint{79, 5.0, 4.0, std::nullopt}};
  CHECK(!ardy::window_goals(waypoints, 40, anchor, s).root_path_only);
  // interpolate_root fills the waypoints into a path over the window.
  ardy::GoalSpec interpolated = s;
  interpolated.interpolate_root = true;
  CHECK(ardy::window_goals(waypoints, 40, anchor, interpolated).root_path_only);
  // Anything besides the root, in the window or the future, keeps the full guidance.
  CHECK(!ardy::window_goals(std::vector<Constraint>{path(40, 40), FootContact{42, 44, {0}, 1.0}}, 40, anchor, s).root_path_only);
  JointTarget hand;
  hand.frame = 85;  // a future frame
  hand.joint = 3;
  hand.position = glm::dvec3{0.0, 1.0, 0.3};
  CHECK(!ardy::window_goals(std::vector<Constraint>{path(40, 40), hand}, 40, anchor, s).root_path_only);
  CHECK(!ardy::window_goals(std::vector<Constraint>{}, 40, anchor, s).root_path_only);
}

TEST_CASE("window goals: max_root_speed pulls root targets back so nothing asks for a teleport",
          "[constraints][goals]") {
  const ardy::Normalization norm = unit_stats();
  ardy::GoalSpec s = spec(norm);
  s.fps = 20.0;
  s.max_root_speed = 6.0;  // 0.3 m per frame
  std::vector<Constraint> constraints;
  constraints.push_back(RootWaypoint{49, 11.0, 2.0, std::nullopt});  // 10 m in 10 frames: 3 m reachable
  constraints.push_back(RootPath{50, {{4.0, 6.0}, {4.0, 6.1}}, {}});  // 4 m beside the pulled-back waypoint
  const glm::dvec2 anchor{1.0, 2.0};
  const WindowGoals g = ardy::window_goals(constraints, 40, anchor, s);
  CHECK_THAT(goal_at(g, 9, 0), WithinAbs(3.0, 1e-6));
  CHECK_THAT(goal_at(g, 9, 2), WithinAbs(0.0, 1e-6));
  CHECK_THAT(goal_at(g, 10, 0), WithinAbs(3.0, 1e-6));  // joined at the limit, not 4 m in one frame
  CHECK_THAT(goal_at(g, 10, 2), WithinAbs(0.3, 1e-6));
  CHECK_THAT(goal_at(g, 11, 2), WithinAbs(0.6, 1e-6));
  CHECK(count_mask(g.window_goal_mask) == 3 * 2);
  // With interpolation the path to the waypoint is limited the same way.
  s.interpolate_root = true;
  const WindowGoals path = ardy::window_goals(constraints, 40, anchor, s);
  for (size_t f = 0; f <= 9; ++f) CHECK_THAT(goal_at(path, f, 0), WithinAbs(0.3 * double(f + 1), 1e-6));
  // No limit: the targets as given.
  const WindowGoals free = ardy::window_goals(constraints, 40, anchor, spec(norm));
  CHECK_THAT(goal_at(free, 9, 0), WithinAbs(10.0, 1e-6));
  // The limit needs the frame rate and a sane value.
  ardy::GoalSpec no_fps = spec(norm);
  no_fps.max_root_speed = 6.0;
  CHECK_THAT(error_message([&] { ardy::window_goals(constraints, 40, anchor, no_fps); }),
             ContainsSubstring("max_root_speed needs the fps"));
  s.max_root_speed = -1.0;
  CHECK_THAT(error_message([&] { ardy::window_goals(constraints, 40, anchor, s); }),
             ContainsSubstring("max_root_speed is -1"));
}

TEST_CASE("window goals: keyframes, root joint targets and rotations", "[constraints][goals]") {
  const ardy::Normalization norm = unit_stats();
  PoseKeyframe key;
  key.frame = 2;
  key.features.resize(258);
  for (size_t i = 0; i < 258; ++i) key.features[i] = double(i) / 100.0;
  key.include_root = false;
  JointTarget root;
  root.frame = 3;
  root.joint = 0;
  root.position = glm::dvec3(2.0, 0.9, 3.0);
  JointTarget turn;
  turn.frame = 4;
  turn.joint = 5;
  glm::dmat3 r(0.0);
  r[0] = glm::dvec3(0, 1, 0);  // column 0
  r[1] = glm::dvec3(-1, 0, 0);
  r[2] = glm::dvec3(0, 0, 1);
  turn.rotation = r;
  const WindowGoals g = ardy::window_goals(std::vector<Constraint>{key, root, turn}, 0, {1.0, 1.0}, spec(norm, 10, 0));
  CHECK(goal_at(g, 2, 0, true) == 0.0f);  // include_root false
  CHECK(goal_at(g, 2, 5) == 0.05f);
  CHECK(goal_at(g, 2, 190) == 1.90f);
  CHECK(goal_at(g, 2, 191, true) == 0.0f);  // velocities not constrained
  CHECK(goal_at(g, 2, 254, true) == 0.0f);  // contacts not constrained
  CHECK(count_mask(g.window_goal_mask) == 126 + 60 + 3 + 6);
  CHECK(goal_at(g, 3, 0) == 1.0f);  // root joint: world position, re-centred
  CHECK(goal_at(g, 3, 1) == 0.9f);
  CHECK(goal_at(g, 3, 2) == 2.0f);
  const size_t six = layout().rotation_6d_of(5).start;
  const std::vector<float> expected{0, 1, 0, -1, 0, 0};
  for (size_t i = 0; i < 6; ++i) CHECK(goal_at(g, 4, six + i) == expected[i]);
}

TEST_CASE("window goals of the golden rollout windows from the golden constraints", "[constraints][goals][parity]") {
  const auto package = tiny_package();
  const json& info = goldens().doc().at("rollout");
  json doc;
  doc["constraints"] = info.at("constraints");
  const ardy::Timeline timeline = ardy::parse_timeline(doc, *package, "goldens.json");
  REQUIRE(timeline.constraints.size() == 6);
  ardy::GoalSpec s;
  s.layout = &package->layout();
  s.normalization = &package->feature_normalization();
  s.patch = package->tokens().patch;
  s.window_tokens = package->tokens().window;
  s.future_limit_tokens = info.at("config").at("future_tokens").get<size_t>();
  for (size_t w = 0; w < info.at("windows").get<size_t>(); ++w) {
    const std::string name = "rollout/window" + std::to_string(w) + "/";
    const std::vector<float> offset = goldens().floats(name + "offset");
    const WindowGoals g =
        ardy::window_goals(timeline.constraints, info.at("window_starts")[w].get<int64_t>(), {offset[0], offset[1]}, s);
    REQUIRE(static_cast<int64_t>(g.future_tokens) == goldens().shape(name + "future_goal")[0]);
    ardy_test::check_parity(name + "window_goal (direct)", goldens().floats(name + "window_goal"), g.window_goal, 1e-6);
    CHECK(g.window_goal_mask == goldens().floats(name + "window_goal_mask"));
    ardy_test::check_parity(name + "future_goal (direct)", goldens().floats(name + "future_goal"), g.future_goal, 1e-6);
    CHECK(g.future_goal_mask == goldens().floats(name + "future_goal_mask"));
    CHECK(g.future_mask == goldens().floats(name + "future_mask"));
  }
}

// --- JSON timelines --------------------------------------------------------------------------------------------

TEST_CASE("JSON timelines in seconds (timeline.py schema) and frame forms", "[constraints][timeline]") {
  const auto package = tiny_package();
  const json doc = json::parse(R"({
    "prompts": [{"time": 0, "text": "a person walks"}, {"time": 4, "text": "a person waves"}, {"time": 6, "text": null}],
    "constraints": [
      {"type": "waypoint", "time": 3.0, "x": 1.0, "z": 4.0, "heading": 0.0},
      {"type": "path", "start_time": 0.0, "points": [[0, 0], [0, 5]], "speed": 1.2},
      {"type": "joint", "time": 2.0, "joint": "Hand_R", "position": [0.3, 1.5, 0.4]},
      {"type": "contact", "start_time": 1.0, "end_time": 2.0, "feet": [0, "Foot_R"], "value": 1},
      {"type": "waypoint", "time": 0.025, "x": 0, "z": 0},
      {"type": "waypoint", "time": 0.075, "x": 0, "z": 0},
      {"type": "clicks", "points": [[0, 0], [1, 0], [1, 1]], "speed": 1.0, "start_frame": 5},
      {"type": "joint", "frame": 9, "joint": 3, "rotation": [[1, 0, 0], [0, 0, -1], [0, 1, 0]]},
      {"type": "path", "start_frame": 2, "positions": [[0, 0], [0.1, 0.1]], "headings": [0.1, 0.2]}
    ]})");
  const ardy::Timeline t = ardy::parse_timeline(doc, *package, "timeline.json");
  REQUIRE(t.prompts.size() == 3);
  CHECK(t.prompts[1].frame == 80);
  CHECK(!t.prompts[2].text.has_value());
  REQUIRE(t.constraints.size() == 9);
  CHECK(std::get<RootWaypoint>(t.constraints[0]).frame == 60);
  CHECK(std::get<RootPath>(t.constraints[1]).positions.size() == 84);
  CHECK(std::get<JointTarget>(t.constraints[2]).joint == 12);
  const FootContact& contact = std::get<FootContact>(t.constraints[3]);
  CHECK(contact.start_frame == 20);
  CHECK(contact.end_frame == 40);
  CHECK(contact.feet == std::vector<size_t>{0, 2});
  CHECK(std::get<RootWaypoint>(t.constraints[4]).frame == 0);  // 0.5 rounds to even
  CHECK(std::get<RootWaypoint>(t.constraints[5]).frame == 2);  // 1.5 rounds to even
  CHECK(std::get<RootPath>(t.constraints[6]).start_frame == 5);
  const glm::dmat3 rot = *std::get<JointTarget>(t.constraints[7]).rotation;
  CHECK(rot[2][1] == -1.0);  // row 1, column 2
  CHECK(std::get<RootPath>(t.constraints[8]).headings.size() == 2);
}

TEST_CASE("bad JSON timelines name the entry and the field", "[constraints][timeline][errors]") {
  const auto package = tiny_package();
  const auto error = [&](const std::string& text) {
    return error_message([&] { ardy::parse_timeline_text(text, *package, "t.json"); });
  };
  CHECK_THAT(error(R"({"constraints": [{"type": "joint", "time": 1, "joint": "Hand", "position": [0, 1, 0]}]})"),
             ContainsSubstring("t.json: constraints[0] (joint): skeleton: unknown joint 'Hand' (the skeleton's joints "
                               "are Hips, Spine"));
  CHECK_THAT(error(R"({"constraints": [{"type": "teleport", "time": 1}]})"),
             ContainsSubstring("t.json: constraints[0]: unknown type 'teleport'"));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": 1, "x": 1}]})"),
             ContainsSubstring("t.json: constraints[0] (waypoint): missing field 'z'"));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": 1, "x": 1, "z": 2, "hedaing": 1}]})"),
             ContainsSubstring("unknown field 'hedaing'"));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": 1, "x": "left", "z": 2}]})"),
             ContainsSubstring("(waypoint): x must be a number, found \"left\""));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": 1, "x": 1e999, "z": 2}]})"),
             ContainsSubstring("t.json: not valid JSON") && ContainsSubstring("number overflow"));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "x": 1, "z": 2}]})"),
             ContainsSubstring("missing field 'time' (or 'frame')"));
  CHECK_THAT(error(R"({"constraints": [{"type": "path", "points": [[0, 0]], "speed": 1}]})"),
             ContainsSubstring("constraints[0] (path): path_from_polyline: needs at least 2 points"));
  CHECK_THAT(
      error(R"({"constraints": [{"type": "contact", "start_time": 2, "end_time": 1}]})"),
      ContainsSubstring("t.json: constraints[0] (FootContact): end_frame 20 must be greater than start_frame 40"));
  CHECK_THAT(error(R"({"constraints": [{"type": "contact", "start_time": 1, "end_time": 2, "feet": ["Hand_L"]}]})"),
             ContainsSubstring("feet[0] is 'Hand_L', not a contact joint (Foot_L, Toes_L, Foot_R, Toes_R)"));
  CHECK_THAT(error(R"({"constraints": [{"type": "keyframe", "frame": 1, "features": [1, 2]}]})"),
             ContainsSubstring("(PoseKeyframe): features has 2 values, expected 258"));
  CHECK_THAT(error(R"({"prompts": [{"time": 0, "text": ""}]})"),
             ContainsSubstring("t.json: prompts[0]: text: prompt is empty"));
  CHECK_THAT(error(R"({"prompts": [{"time": 0}]})"), ContainsSubstring("prompts[0]: missing field 'text'"));
  CHECK_THAT(error(R"({"prompt": []})"), ContainsSubstring("t.json: unknown field 'prompt'"));
  CHECK_THAT(error("[1, 2"), ContainsSubstring("t.json: not valid JSON"));
}

TEST_CASE("JSON timelines refuse negative or huge times and out-of-range numbers", "[constraints][timeline][errors]") {
  const auto package = tiny_package();
  const auto error = [&](const std::string& text) {
    return error_message([&] { ardy::parse_timeline_text(text, *package, "t.json"); });
  };
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": -5, "x": 0, "z": 0}]})"),
             ContainsSubstring("t.json: constraints[0] (waypoint): time is -5 s, expected 0..1e7 s"));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": 2e7, "x": 0, "z": 0}]})"),
             ContainsSubstring("time is 2e+07 s, expected 0..1e7 s"));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "frame": -3, "x": 0, "z": 0}]})"),
             ContainsSubstring("(waypoint): frame is -3, expected 0..200000000"));
  CHECK_THAT(error(R"({"prompts": [{"time": -0.5, "text": "walk"}]})"),
             ContainsSubstring("t.json: prompts[0]: time is -0.5 s, expected 0..1e7 s"));
  CHECK_THAT(error(R"({"constraints": [{"type": "contact", "start_time": -1, "end_time": 2}]})"),
             ContainsSubstring("(contact): start_time is -1 s"));
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": 1, "x": 1e300, "z": 0}]})"),
             ContainsSubstring("t.json: constraints[0] (RootWaypoint): x is 1e+300, outside +-1e+06 m"));
  CHECK_THAT(error(R"({"constraints": [{"type": "path", "points": [[0, 0], [0, 5]], "speed": 1e30}]})"),
             ContainsSubstring("(path): path_from_polyline: speed is 1e+30, expected a positive finite speed up to 100"));
  CHECK_THAT(error(R"({"constraints": [{"type": "clicks", "points": [[0, 0], [0, 1e7]]}]})"),
             ContainsSubstring("(clicks): path_from_clicks: points[1] is (0, 1e+07), outside +-1e6 m"));
  CHECK_THAT(error(R"({"constraints": [{"type": "joint", "time": 1, "joint": 3, "position": [0, -1e300, 0]}]})"),
             ContainsSubstring("position.y is -1e+300, outside +-1e+06 m"));
  CHECK_THAT(error(R"({"constraints": [{"type": "contact", "start_time": 1, "end_time": 2, "value": 7}]})"),
             ContainsSubstring("value is 7, expected 0 (free) .. 1 (planted)"));
  // NaN and infinity cannot be written in JSON, and a number that overflows is refused by the parser.
  CHECK_THAT(error(R"({"constraints": [{"type": "waypoint", "time": 1e999, "x": 0, "z": 0}]})"),
             ContainsSubstring("t.json: not valid JSON") && ContainsSubstring("number overflow"));
}
