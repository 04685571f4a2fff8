#include "constraints.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <glm/geometric.hpp>

#include "kinematics.hpp"

namespace ardy {
namespace {

// Frames beyond this are refused: they keep every frame difference far from
// int64 overflow and are hours past any real timeline.
constexpr int64_t kMaxFrame = int64_t{1} << 40;
// A dense path longer than this (about 14 hours at 20 fps) is a mistake.
constexpr size_t kMaxPathFrames = size_t{1} << 20;
// Numbers that parse but are no motion are refused, never used (constraints.hpp
// "Bounds"): a position 1e300 m away would overflow the goal arithmetic and a
// speed of 1e30 m/s would make a one-frame path.
constexpr double kMaxCoordinate = 1e6;  // metres from the origin, per axis
constexpr double kMaxHeading = 1e6;     // radians (any angle, many turns over)
constexpr double kMaxFeature = 1e6;     // a keyframe's world features (metres, 6D, cos/sin)
constexpr double kMaxSpeed = 100.0;     // m/s along a path

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

std::string number_text(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+infinity" : "-infinity";
  std::ostringstream out;
  out << v;
  return out.str();
}

class Checker {
 public:
  Checker(const std::string& where, const char* type) : prefix_(where + " (" + type + "): ") {}

  [[noreturn]] void fail(const std::string& what) const { throw Error(prefix_ + what); }

  void finite(const std::string& field, double v) const {
    if (!std::isfinite(v)) fail(field + " is " + number_text(v) + " (values must be finite)");
  }
  void frame(const std::string& field, int64_t f) const {
    if (f < -kMaxFrame || f > kMaxFrame) {
      fail(field + " is " + std::to_string(f) + ", outside +-" + std::to_string(kMaxFrame));
    }
  }
  // Finite and within +-limit (`what`: why the bound, for the message).
  void bounded(const std::string& field, double v, double limit, const char* what) const {
    finite(field, v);
    if (std::fabs(v) > limit) fail(field + " is " + number_text(v) + ", outside +-" + number_text(limit) + " " + what);
  }
  void coordinate(const std::string& field, double v) const {
    bounded(field, v, kMaxCoordinate, "m (positions must lie within 1e6 m of the origin)");
  }
  void heading(const std::string& field, double v) const { bounded(field, v, kMaxHeading, "rad"); }
  void vec3(const std::string& field, const glm::dvec3& v) const {
    coordinate(field + ".x", v.x);
    coordinate(field + ".y", v.y);
    coordinate(field + ".z", v.z);
  }

 private:
  std::string prefix_;
};

// numpy.interp for increasing xp (compiled_base.c arr_interp), including its
// handling of repeated xp values.
double np_interp(double x, const std::vector<double>& xp, const std::vector<double>& fp) {
  const size_t n = xp.size();
  if (x < xp.front()) return fp.front();
  if (x > xp.back()) return fp.back();
  // j with xp[j] <= x < xp[j + 1] (the last such j for repeated values).
  const size_t j = static_cast<size_t>(std::upper_bound(xp.begin(), xp.end(), x) - xp.begin()) - 1;
  if (j == n - 1) return fp[j];
  if (xp[j] == x) return fp[j];
  const double slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]);
  double result = slope * (x - xp[j]) + fp[j];
  if (std::isnan(result)) {
    result = slope * (x - xp[j + 1]) + fp[j + 1];
    if (std::isnan(result) && fp[j] == fp[j + 1]) result = fp[j];
  }
  return result;
}

void check_path_inputs(const char* what, const std::vector<glm::dvec2>& points, double speed, double fps) {
  const std::string name(what);
  if (points.size() < 2) {
    throw Error(name + ": needs at least 2 points, got " + std::to_string(points.size()));
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i].x) || !std::isfinite(points[i].y)) {
      throw Error(name + ": points[" + std::to_string(i) + "] is not finite");
    }
    if (std::fabs(points[i].x) > kMaxCoordinate || std::fabs(points[i].y) > kMaxCoordinate) {
      throw Error(name + ": points[" + std::to_string(i) + "] is (" + number_text(points[i].x) + ", " +
                  number_text(points[i].y) + "), outside +-1e6 m (positions must lie within 1e6 m of the origin)");
    }
  }
  if (!std::isfinite(speed) || !(speed > 0.0) || speed > kMaxSpeed) {
    throw Error(name + ": speed is " + number_text(speed) + ", expected a positive finite speed up to " +
                number_text(kMaxSpeed) + " m/s");
  }
  if (!std::isfinite(fps) || !(fps > 0.0)) throw Error(name + ": fps is " + number_text(fps) + ", expected > 0");
}

}  // namespace

// --- constraints -----------------------------------------------------------------

JointTarget JointTarget::from_world(int64_t frame, size_t joint, const glm::dvec3& world_position,
                                    const glm::dvec2& root_xz, std::optional<glm::dmat3> rotation) {
  JointTarget target;
  target.frame = frame;
  target.joint = joint;
  glm::dvec3 rel = world_position;
  if (joint != 0) {
    rel.x -= root_xz.x;
    rel.z -= root_xz.y;
  }
  target.position = rel;
  target.rotation = rotation;
  return target;
}

const char* constraint_type_name(const Constraint& constraint) {
  return std::visit(
      Overloaded{[](const RootWaypoint&) { return "RootWaypoint"; }, [](const RootPath&) { return "RootPath"; },
                 [](const PoseKeyframe&) { return "PoseKeyframe"; }, [](const JointTarget&) { return "JointTarget"; },
                 [](const FootContact&) { return "FootContact"; }},
      constraint);
}

std::pair<int64_t, int64_t> constraint_frames(const Constraint& constraint) {
  return std::visit(Overloaded{[](const RootPath& c) {
                                 return std::make_pair(c.start_frame,
                                                       c.start_frame + static_cast<int64_t>(c.positions.size()) - 1);
                               },
                               [](const FootContact& c) { return std::make_pair(c.start_frame, c.end_frame - 1); },
                               [](const auto& c) { return std::make_pair(c.frame, c.frame); }},
                    constraint);
}

bool constrains_root_position(const Constraint& constraint) {
  return std::visit(Overloaded{[](const RootWaypoint&) { return true; }, [](const RootPath&) { return true; },
                               [](const PoseKeyframe& c) { return c.include_root; },
                               [](const JointTarget& c) { return c.joint == 0 && c.position.has_value(); },
                               [](const FootContact&) { return false; }},
                    constraint);
}

void validate_constraint(const Constraint& constraint, const FeatureLayout& layout, const std::string& where) {
  const Checker check(where, constraint_type_name(constraint));
  std::visit(
      Overloaded{[&](const RootWaypoint& c) {
                   check.frame("frame", c.frame);
                   check.coordinate("x", c.x);
                   check.coordinate("z", c.z);
                   if (c.heading) check.heading("heading", *c.heading);
                 },
                 [&](const RootPath& c) {
                   check.frame("start_frame", c.start_frame);
                   if (c.positions.empty()) check.fail("positions is empty (a path needs at least one frame)");
                   if (c.positions.size() > kMaxPathFrames) {
                     check.fail("positions has " + std::to_string(c.positions.size()) + " frames, more than the " +
                                std::to_string(kMaxPathFrames) + " allowed");
                   }
                   for (size_t i = 0; i < c.positions.size(); ++i) {
                     check.coordinate("positions[" + std::to_string(i) + "].x", c.positions[i].x);
                     check.coordinate("positions[" + std::to_string(i) + "].z", c.positions[i].y);
                   }
                   if (!c.headings.empty() && c.headings.size() != c.positions.size()) {
                     check.fail("headings has " + std::to_string(c.headings.size()) +
                                " entries, expected one per position (" + std::to_string(c.positions.size()) +
                                ") or none");
                   }
                   for (size_t i = 0; i < c.headings.size(); ++i)
                     check.heading("headings[" + std::to_string(i) + "]", c.headings[i]);
                 },
                 [&](const PoseKeyframe& c) {
                   check.frame("frame", c.frame);
                   if (c.features.size() != layout.feature_size) {
                     check.fail("features has " + std::to_string(c.features.size()) + " values, expected " +
                                std::to_string(layout.feature_size) + " (features.size of the model)");
                   }
                   for (size_t i = 0; i < c.features.size(); ++i) {
                     check.bounded("features[" + std::to_string(i) + "]", c.features[i], kMaxFeature,
                                   "(world features: metres, rotations, cos/sin)");
                   }
                 },
                 [&](const JointTarget& c) {
                   check.frame("frame", c.frame);
                   if (c.joint >= layout.joint_count) {
                     check.fail("joint " + std::to_string(c.joint) + " is out of range (the skeleton has joints 0.." +
                                std::to_string(layout.joint_count - 1) + ")");
                   }
                   if (!c.position && !c.rotation) check.fail("has neither a position nor a rotation");
                   if (c.position) check.vec3("position", *c.position);
                   if (c.rotation) {
                     for (int col = 0; col < 3; ++col) {
                       for (int row = 0; row < 3; ++row) {
                         check.bounded("rotation[" + std::to_string(row) + "][" + std::to_string(col) + "]",
                                       (*c.rotation)[col][row], 1e3, "(a rotation matrix)");
                       }
                     }
                   }
                 },
                 [&](const FootContact& c) {
                   check.frame("start_frame", c.start_frame);
                   check.frame("end_frame", c.end_frame);
                   if (c.end_frame <= c.start_frame) {
                     check.fail("end_frame " + std::to_string(c.end_frame) + " must be greater than start_frame " +
                                std::to_string(c.start_frame));
                   }
                   for (size_t i = 0; i < c.feet.size(); ++i) {
                     if (c.feet[i] >= layout.contact_count()) {
                       check.fail("feet[" + std::to_string(i) + "] is " + std::to_string(c.feet[i]) +
                                  ", expected a contact index 0.." + std::to_string(layout.contact_count()) + "-1");
                     }
                   }
                   check.finite("value", c.value);
                   if (c.value < 0.0 || c.value > 1.0) {
                     check.fail("value is " + number_text(c.value) + ", expected 0 (free) .. 1 (planted)");
                   }
                 }},
      constraint);
}

size_t joint_index(const Skeleton& skeleton, const std::string& name) { return skeleton.index_of(name); }

// --- path helpers ------------------------------------------------------------------

RootPath path_from_polyline(const std::vector<glm::dvec2>& points, double speed, int64_t start_frame, double fps,
                            bool with_heading) {
  check_path_inputs("path_from_polyline", points, speed, fps);
  const size_t segments = points.size() - 1;
  std::vector<double> cum(points.size(), 0.0);
  std::vector<double> xs(points.size()), zs(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    xs[i] = points[i].x;
    zs[i] = points[i].y;
  }
  for (size_t i = 0; i < segments; ++i) {
    const double dx = points[i + 1].x - points[i].x;
    const double dz = points[i + 1].y - points[i].y;
    cum[i + 1] = cum[i] + std::sqrt(dx * dx + dz * dz);
  }
  const double frames = std::floor(cum.back() / speed * fps) + 1.0;
  if (!(frames <= double(kMaxPathFrames))) {
    throw Error("path_from_polyline: the path is " + number_text(cum.back()) + " m long, " + number_text(frames) +
                " frames at this speed, more than the " + std::to_string(kMaxPathFrames) + " allowed");
  }
  const auto count = static_cast<size_t>(frames);
  RootPath path;
  path.start_frame = start_frame;
  path.positions.resize(count);
  if (with_heading) path.headings.resize(count);
  for (size_t k = 0; k < count; ++k) {
    const double dist = static_cast<double>(k) * speed / fps;
    path.positions[k] = glm::dvec2(np_interp(dist, cum, xs), np_interp(dist, cum, zs));
    if (with_heading) {
      const auto upper = static_cast<int64_t>(std::upper_bound(cum.begin(), cum.end(), dist) - cum.begin()) - 1;
      const auto idx = static_cast<size_t>(std::clamp<int64_t>(upper, 0, static_cast<int64_t>(segments) - 1));
      path.headings[k] = std::atan2(points[idx + 1].x - points[idx].x, points[idx + 1].y - points[idx].y);
    }
  }
  return path;
}

RootPath path_from_clicks(const std::vector<glm::dvec2>& points, double speed, int64_t start_frame, double fps,
                          size_t smoothing_frames) {
  check_path_inputs("path_from_clicks", points, speed, fps);
  const RootPath linear = path_from_polyline(points, speed, start_frame, fps, false);
  const size_t n = linear.positions.size();
  RootPath path;
  path.start_frame = start_frame;
  path.positions.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const size_t r = std::min({smoothing_frames, i, n - 1 - i});
    glm::dvec2 sum(0.0);
    for (size_t k = i - r; k <= i + r; ++k) sum += linear.positions[k];
    path.positions[i] = sum / static_cast<double>(2 * r + 1);
  }
  // Headings along the smoothed path (central differences); where it does
  // not move, the previous heading (at first, the first clicked direction).
  double heading = 0.0;
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    const glm::dvec2 d = points[i + 1] - points[i];
    if (d.x != 0.0 || d.y != 0.0) {
      heading = std::atan2(d.x, d.y);
      break;
    }
  }
  path.headings.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec2 d = path.positions[std::min(i + 1, n - 1)] - path.positions[i > 0 ? i - 1 : 0];
    if (d.x * d.x + d.y * d.y > 1e-18) heading = std::atan2(d.x, d.y);
    path.headings[i] = heading;
  }
  return path;
}

RootPath path_from_velocity(const glm::dvec2& position, const glm::dvec2& current_velocity,
                            const glm::dvec2& target_velocity, int64_t start_frame, size_t frames, size_t blend_frames,
                            double fps, std::optional<double> current_heading) {
  const auto finite2 = [](const glm::dvec2& v) { return std::isfinite(v.x) && std::isfinite(v.y); };
  if (!finite2(position)) throw Error("path_from_velocity: position is not finite");
  if (!finite2(current_velocity)) throw Error("path_from_velocity: current_velocity is not finite");
  if (!finite2(target_velocity)) throw Error("path_from_velocity: target_velocity is not finite");
  if (current_heading && !std::isfinite(*current_heading)) {
    throw Error("path_from_velocity: current_heading is not finite");
  }
  if (!std::isfinite(fps) || !(fps > 0.0))
    throw Error("path_from_velocity: fps is " + number_text(fps) + ", expected > 0");
  if (frames == 0 || frames > kMaxPathFrames) {
    throw Error("path_from_velocity: frames is " + std::to_string(frames) + ", expected 1.." +
                std::to_string(kMaxPathFrames));
  }
  constexpr double kMinSpeed = 1e-3;
  RootPath path;
  path.start_frame = start_frame;
  path.positions.resize(frames);
  std::vector<std::optional<double>> directions(frames);
  glm::dvec2 p = position;
  for (size_t k = 0; k < frames; ++k) {
    const double a = blend_frames == 0 ? 1.0 : std::min(1.0, double(k + 1) / double(blend_frames));
    const glm::dvec2 v = current_velocity + (target_velocity - current_velocity) * a;
    p += v / fps;
    path.positions[k] = p;
    if (std::sqrt(v.x * v.x + v.y * v.y) >= kMinSpeed) directions[k] = std::atan2(v.x, v.y);
  }
  std::optional<double> heading = current_heading;
  if (!heading) {
    for (const auto& d : directions) {
      if (d) {
        heading = d;
        break;
      }
    }
  }
  if (!heading) return path;  // never moves, no heading known: positions only
  path.headings.resize(frames);
  for (size_t k = 0; k < frames; ++k) {
    if (directions[k]) heading = directions[k];
    path.headings[k] = *heading;
  }
  return path;
}

std::vector<double> pose_features(const FeatureLayout& layout, const std::vector<glm::mat3>& global_rotations,
                                  const std::vector<glm::vec3>& positions, double heading) {
  if (global_rotations.size() != layout.joint_count || positions.size() != layout.joint_count) {
    throw Error("pose_features: " + std::to_string(global_rotations.size()) + " rotations and " +
                std::to_string(positions.size()) + " positions for a layout of " + std::to_string(layout.joint_count) +
                " joints");
  }
  std::vector<double> f(layout.feature_size, 0.0);
  const glm::vec3& p = positions[0];
  f[layout.root_position.start + 0] = p.x;
  f[layout.root_position.start + 1] = p.y;
  f[layout.root_position.start + 2] = p.z;
  f[layout.heading.start] = std::cos(heading);
  f[layout.heading.start + 1] = std::sin(heading);
  for (size_t j = 0; j < layout.joint_count; ++j) {
    float six[6];
    rotation_to_6d(global_rotations[j], six);
    for (size_t i = 0; i < 6; ++i) f[layout.rotation_6d.start + 6 * j + i] = six[i];
  }
  for (size_t j = 1; j < layout.joint_count; ++j) {
    const size_t at = layout.joint_positions.start + 3 * (j - 1);
    f[at + 0] = double(positions[j].x) - double(p.x);
    f[at + 1] = positions[j].y;
    f[at + 2] = double(positions[j].z) - double(p.z);
  }
  return f;
}

// --- timeline --------------------------------------------------------------------------

ConstraintTimeline::ConstraintTimeline(FeatureLayout layout) : layout_(std::move(layout)) { layout_.validate(); }

ConstraintTimeline::Id ConstraintTimeline::add(Constraint constraint) {
  validate_constraint(constraint, layout_, "constraint");
  const Id id = next_id_++;
  entries_.push_back(Entry{id, std::move(constraint)});
  ++revision_;
  return id;
}

bool ConstraintTimeline::remove(Id id) {
  const auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.id == id; });
  if (it == entries_.end()) return false;
  entries_.erase(it);
  ++revision_;
  return true;
}

void ConstraintTimeline::clear() {
  if (entries_.empty()) return;
  entries_.clear();
  ++revision_;
}

std::vector<ConstraintTimeline::Id> ConstraintTimeline::drop_passed(int64_t frame) {
  std::vector<Id> dropped;
  std::vector<Entry> kept;
  kept.reserve(entries_.size());
  for (Entry& e : entries_) {
    if (constraint_frames(e.constraint).second < frame) {
      dropped.push_back(e.id);
    } else {
      kept.push_back(std::move(e));
    }
  }
  entries_ = std::move(kept);
  if (!dropped.empty()) ++revision_;
  return dropped;
}

const Constraint* ConstraintTimeline::find(Id id) const {
  for (const Entry& e : entries_) {
    if (e.id == id) return &e.constraint;
  }
  return nullptr;
}

ConstraintTimeline::Split ConstraintTimeline::split(int64_t window_start, int64_t horizon_frames) const {
  Split out;
  const int64_t end = window_start + horizon_frames;
  for (const Entry& e : entries_) {
    const auto [first, last] = constraint_frames(e.constraint);
    if (last < window_start) {
      out.passed.push_back(e.id);
    } else if (first >= end) {
      out.waiting.push_back(e.id);
    } else {
      out.active.push_back(e.id);
    }
  }
  return out;
}

// --- per-window goals ----------------------------------------------------------------------

bool WindowGoals::has_constraints() const {
  if (any_window_constraint) return true;
  return std::any_of(future_mask.begin(), future_mask.end(), [](float v) { return v != 0.0f; });
}

namespace {

// The float64 goal and mask of frames [first, first + count), M per frame.
class Raster {
 public:
  Raster(const FeatureLayout& layout, int64_t first, size_t count)
      : layout_(layout),
        first_(first),
        count_(count),
        goal_(count * layout.feature_size, 0.0),
        mask_(count * layout.feature_size, 0.0) {}

  void put(int64_t frame, size_t feature, double value) {
    const int64_t i = frame - first_;
    if (i < 0 || i >= static_cast<int64_t>(count_)) return;
    const size_t at = static_cast<size_t>(i) * layout_.feature_size + feature;
    goal_[at] = value;
    mask_[at] = 1.0;
  }
  bool in_range(int64_t frame) const { return frame >= first_ && frame - first_ < static_cast<int64_t>(count_); }

  void add(const Constraint& constraint) {
    const FeatureLayout& l = layout_;
    const size_t px = l.root_position.start, pz = px + 2;
    const size_t hc = l.heading.start, hs = hc + 1;
    std::visit(Overloaded{[&](const RootWaypoint& c) {
                            put(c.frame, px, c.x);
                            put(c.frame, pz, c.z);
                            if (c.heading) {
                              put(c.frame, hc, std::cos(*c.heading));
                              put(c.frame, hs, std::sin(*c.heading));
                            }
                          },
                          [&](const RootPath& c) {
                            for (size_t k = 0; k < c.positions.size(); ++k) {
                              const int64_t f = c.start_frame + static_cast<int64_t>(k);
                              if (!in_range(f)) continue;
                              put(f, px, c.positions[k].x);
                              put(f, pz, c.positions[k].y);
                              if (!c.headings.empty()) {
                                put(f, hc, std::cos(c.headings[k]));
                                put(f, hs, std::sin(c.headings[k]));
                              }
                            }
                          },
                          [&](const PoseKeyframe& c) {
                            if (!in_range(c.frame)) return;
                            const auto copy = [&](FeatureSlice s) {
                              for (size_t i = s.start; i < s.stop(); ++i) put(c.frame, i, c.features[i]);
                            };
                            if (c.include_root) copy(l.root());
                            copy(l.rotation_6d);
                            copy(l.joint_positions);
                          },
                          [&](const JointTarget& c) {
                            if (!in_range(c.frame)) return;
                            if (c.position) {
                              const FeatureSlice s = c.joint == 0 ? l.root_position : l.joint_position_of(c.joint);
                              for (size_t i = 0; i < 3; ++i) put(c.frame, s.start + i, (*c.position)[int(i)]);
                            }
                            if (c.rotation) {
                              const glm::dmat3& r = *c.rotation;
                              const FeatureSlice s = l.rotation_6d_of(c.joint);
                              const double six[6] = {r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2]};
                              for (size_t i = 0; i < 6; ++i) put(c.frame, s.start + i, six[i]);
                            }
                          },
                          [&](const FootContact& c) {
                            std::vector<size_t> feet = c.feet;
                            if (feet.empty()) {
                              for (size_t i = 0; i < l.contact_count(); ++i) feet.push_back(i);
                            }
                            const int64_t from = std::max(c.start_frame, first_);
                            const int64_t to = std::min(c.end_frame, first_ + static_cast<int64_t>(count_));
                            for (int64_t f = from; f < to; ++f) {
                              for (size_t foot : feet) put(f, l.foot_contacts.start + foot, c.value);
                            }
                          }},
               constraint);
  }

  // GoalSpec::interpolate_root: anchor is the root (x, z) of the frame before the first.
  void interpolate_root(const glm::dvec2& anchor) {
    walk_root_targets(anchor, [&](long long previous, const glm::dvec2& from, long long target, const glm::dvec2& to) {
      for (long long k = previous + 1; k < target; ++k) {
        const double a = static_cast<double>(k - previous) / static_cast<double>(target - previous);
        set_root(k, from + a * (to - from));
      }
      return to;
    });
  }

  // GoalSpec::max_root_speed: max_step is metres per frame.
  void limit_root_speed(const glm::dvec2& anchor, double max_step) {
    walk_root_targets(anchor, [&](long long previous, const glm::dvec2& from, long long frame, const glm::dvec2& to) {
      const double allowed = max_step * static_cast<double>(frame - previous);
      const double distance = glm::length(to - from);
      const glm::dvec2 reached = distance > allowed ? from + (to - from) * (allowed / distance) : to;
      set_root(frame, reached);
      return reached;
    });
  }

  const std::vector<double>& goal() const { return goal_; }
  const std::vector<double>& mask() const { return mask_; }

 private:
  // Visits the frames whose root x and z are both constrained, in order,
  // starting from `anchor` at frame -1: step(previous, from, frame, to)
  // returns where the root is at `frame` (the next visit's `from`).
  template <typename Step>
  void walk_root_targets(const glm::dvec2& anchor, Step&& step) {
    const size_t m = layout_.feature_size, px = layout_.root_position.start, pz = px + 2;
    long long previous = -1;
    glm::dvec2 from = anchor;
    for (size_t f = 0; f < count_; ++f) {
      if (!(mask_[f * m + px] > 0.0 && mask_[f * m + pz] > 0.0)) continue;
      const long long frame = static_cast<long long>(f);
      from = step(previous, from, frame, glm::dvec2{goal_[f * m + px], goal_[f * m + pz]});
      previous = frame;
    }
  }

  // Constrains the root's x and z at `frame` (relative to the first frame).
  void set_root(long long frame, const glm::dvec2& xz) {
    const size_t m = layout_.feature_size, px = layout_.root_position.start, pz = px + 2;
    const size_t at = static_cast<size_t>(frame) * m;
    goal_[at + px] = xz.x;
    goal_[at + pz] = xz.y;
    mask_[at + px] = 1.0;
    mask_[at + pz] = 1.0;
  }

  const FeatureLayout& layout_;
  int64_t first_;
  size_t count_;
  std::vector<double> goal_;
  std::vector<double> mask_;
};

WindowGoals finish_goals(const Raster& raster, const glm::dvec2& offset, const GoalSpec& spec) {
  const FeatureLayout& layout = *spec.layout;
  const size_t m = layout.feature_size;
  const size_t pm = spec.patch * m;
  const size_t tokens = spec.window_tokens + spec.future_limit_tokens;
  const size_t frames = tokens * spec.patch;
  const std::vector<float>& mean = spec.normalization->mean();
  const std::vector<float>& stddev = spec.normalization->stddev();
  std::vector<float> g(frames * m, 0.0f);
  std::vector<float> v(frames * m, 0.0f);
  const size_t px = layout.root_position.start, pz = px + 2;
  const std::vector<double>& goal = raster.goal();
  const std::vector<double>& mask = raster.mask();
  const size_t window_frames = spec.window_tokens * spec.patch;
  size_t root_path_frames = 0;  // window frames whose root x and z are given
  bool root_entries_only = true;
  for (size_t f = 0; f < frames; ++f) {
    if (f < window_frames && mask[f * m + px] > 0.0 && mask[f * m + pz] > 0.0) ++root_path_frames;
    for (size_t i = 0; i < m; ++i) {
      const size_t at = f * m + i;
      if (!(mask[at] > 0.0)) continue;
      if (i >= layout.heading.stop()) root_entries_only = false;
      double value = goal[at];
      if (i == px) value -= offset.x;
      if (i == pz) value -= offset.y;
      g[at] = static_cast<float>((value - static_cast<double>(mean[i])) / static_cast<double>(stddev[i]));
      v[at] = static_cast<float>(mask[at]);
    }
  }
  WindowGoals out;
  out.window_tokens = spec.window_tokens;
  out.goal_dim = pm;
  const size_t window_values = spec.window_tokens * pm;
  out.window_goal.assign(g.begin(), g.begin() + static_cast<std::ptrdiff_t>(window_values));
  out.window_goal_mask.assign(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(window_values));
  out.any_window_constraint =
      std::any_of(out.window_goal_mask.begin(), out.window_goal_mask.end(), [](float x) { return x != 0.0f; });
  out.root_path_only = root_entries_only && 2 * root_path_frames >= window_frames;
  size_t count = 0;
  std::vector<float> future_any(spec.future_limit_tokens, 0.0f);
  for (size_t k = 0; k < spec.future_limit_tokens; ++k) {
    const auto begin = v.begin() + static_cast<std::ptrdiff_t>(window_values + k * pm);
    if (std::any_of(begin, begin + static_cast<std::ptrdiff_t>(pm), [](float x) { return x != 0.0f; })) {
      future_any[k] = 1.0f;
      count = k + 1;
    }
  }
  out.future_tokens = count;
  const auto fbegin = static_cast<std::ptrdiff_t>(window_values);
  const auto fend = static_cast<std::ptrdiff_t>(window_values + count * pm);
  out.future_goal.assign(g.begin() + fbegin, g.begin() + fend);
  out.future_goal_mask.assign(v.begin() + fbegin, v.begin() + fend);
  out.future_mask.assign(future_any.begin(), future_any.begin() + static_cast<std::ptrdiff_t>(count));
  return out;
}

void check_spec(const GoalSpec& spec) {
  if (spec.layout == nullptr || spec.normalization == nullptr) {
    throw Error("window_goals: GoalSpec needs a layout and the feature normalization");
  }
  if (spec.normalization->size() != spec.layout->feature_size) {
    throw Error("window_goals: " + std::to_string(spec.normalization->size()) + " statistics for " +
                std::to_string(spec.layout->feature_size) + " features");
  }
  if (spec.patch == 0 || spec.window_tokens == 0) throw Error("window_goals: patch and window_tokens must be positive");
  if (!(spec.max_root_speed >= 0.0) || !std::isfinite(spec.max_root_speed)) {
    throw Error("window_goals: max_root_speed is " + number_text(spec.max_root_speed) + ", expected >= 0 m/s");
  }
  if (spec.max_root_speed > 0.0 && !(spec.fps > 0.0 && std::isfinite(spec.fps))) {
    throw Error("window_goals: max_root_speed needs the fps, found " + number_text(spec.fps));
  }
}

template <typename Each>
WindowGoals window_goals_impl(Each&& each, int64_t window_start, const glm::dvec2& offset, const GoalSpec& spec) {
  check_spec(spec);
  if (!std::isfinite(offset.x) || !std::isfinite(offset.y)) throw Error("window_goals: offset is not finite");
  const size_t frames = (spec.window_tokens + spec.future_limit_tokens) * spec.patch;
  Raster raster(*spec.layout, window_start, frames);
  const int64_t end = window_start + static_cast<int64_t>(frames);
  each([&](const Constraint& c) {
    const auto [first, last] = constraint_frames(c);
    if (last < window_start || first >= end) return;  // passed or waiting
    raster.add(c);
  });
  if (spec.interpolate_root) raster.interpolate_root(offset);
  if (spec.max_root_speed > 0.0) raster.limit_root_speed(offset, spec.max_root_speed / spec.fps);
  return finish_goals(raster, offset, spec);
}

}  // namespace

WindowGoals window_goals(const std::vector<Constraint>& constraints, int64_t window_start, const glm::dvec2& offset_xz,
                         const GoalSpec& spec) {
  check_spec(spec);
  for (size_t i = 0; i < constraints.size(); ++i) {
    validate_constraint(constraints[i], *spec.layout, "constraints[" + std::to_string(i) + "]");
  }
  return window_goals_impl(
      [&](const auto& visit) {
        for (const Constraint& c : constraints) visit(c);
      },
      window_start, offset_xz, spec);
}

WindowGoals window_goals(const ConstraintTimeline& timeline, int64_t window_start, const glm::dvec2& offset_xz,
                         const GoalSpec& spec) {
  check_spec(spec);
  if (timeline.layout() != *spec.layout) {
    throw Error("window_goals: the constraint timeline was made for another feature layout (" +
                std::to_string(timeline.layout().feature_size) + " features) than the model's (" +
                std::to_string(spec.layout->feature_size) + ")");
  }
  return window_goals_impl(
      [&](const auto& visit) {
        for (const ConstraintTimeline::Entry& e : timeline.entries()) visit(e.constraint);
      },
      window_start, offset_xz, spec);
}

}  // namespace ardy
