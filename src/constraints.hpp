#pragma once

// World-space constraints, their timeline, and the per-window conversion into
// the denoiser's goal tensors (design.md section 8, docs/model_contract.md
// section 3 step 3). The conversion is a line-by-line port of
// export_tools/ardy_export/sampling/constraints.py (float64 rasterization,
// float32 result), so the goals match the Python reference.
//
// Frames are model frames at the package's fps, counted from the start of
// the rollout; positions are metres, world space, Y up; headings psi are
// radians about +Y, psi = 0 faces +Z.
//
// Kinds:
// - RootWaypoint: the root's ground position (x, z) at a frame, optionally
//   its heading -> goal features p.x, p.z (and cos psi, sin psi).
// - RootPath: a dense path, one (x, z) per frame from start_frame (optionally
//   one heading per frame). path_from_polyline, path_from_clicks and
//   path_from_velocity make one.
// - PoseKeyframe: a full-body pose as world-space explicit features [M]: root
//   (unless include_root is false), 6D rotations and joint positions J are
//   constrained; velocities and contacts are not.
// - JointTarget: position and/or world rotation of one joint. The position of
//   the root joint (0) is its world position (p.x, p.y, p.z); for any other
//   joint it is the J feature: world position minus (p.x, 0, p.z) of the
//   root at that frame (JointTarget::from_world makes it from a world target).
// - FootContact: contact flags of some feet over frames [start, end).
//
// Later constraints override earlier ones on the same feature entries.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "error.hpp"
#include "features.hpp"
#include "skeleton.hpp"

namespace ardy {

struct RootWaypoint {
  int64_t frame = 0;
  double x = 0.0;
  double z = 0.0;
  std::optional<double> heading;
};

struct RootPath {
  int64_t start_frame = 0;
  std::vector<glm::dvec2> positions;  // (x, z), one per frame from start_frame
  std::vector<double> headings;       // empty, or one per position
};

struct PoseKeyframe {
  int64_t frame = 0;
  std::vector<double> features;  // [M] world-space explicit features
  bool include_root = true;
};

struct JointTarget {
  int64_t frame = 0;
  size_t joint = 0;
  std::optional<glm::dvec3> position;  // see the header comment
  std::optional<glm::dmat3> rotation;  // world rotation (GLM: column-major)

  // A target from a world position and the root's ground position (x, z) at
  // that frame (ignored for the root joint, whose target is its world position).
  static JointTarget from_world(int64_t frame, size_t joint, const glm::dvec3& world_position,
                                const glm::dvec2& root_xz, std::optional<glm::dmat3> rotation = std::nullopt);
};

struct FootContact {
  int64_t start_frame = 0;
  int64_t end_frame = 0;     // exclusive
  std::vector<size_t> feet;  // indices into the contact flags; empty = all of them
  double value = 1.0;        // 0 or 1 in training data
};

using Constraint = std::variant<RootWaypoint, RootPath, PoseKeyframe, JointTarget, FootContact>;

// "RootWaypoint", "RootPath", ...
const char* constraint_type_name(const Constraint& constraint);
// First and last frame (inclusive) a constraint touches.
std::pair<int64_t, int64_t> constraint_frames(const Constraint& constraint);

// Refuses NaN and infinity, joints or feet out of range, a keyframe of the
// wrong size, an empty path, headings of the wrong count and empty contact
// ranges. Bounds (numbers that parse but are no motion are refused, never
// clamped): positions (waypoint x/z, path positions, joint targets) within
// +-1e6 m of the origin per axis, headings within +-1e6 rad, keyframe
// features within +-1e6, rotation matrix entries within +-1e3, contact values
// in 0..1, frames within +-2^40; path helpers: points within +-1e6 m, speeds
// in (0, 100] m/s. Errors start with `where` (e.g. "constraints[3]") and name the
// type and field: "constraints[3] (RootPath): positions[12].x is NaN".
void validate_constraint(const Constraint& constraint, const FeatureLayout& layout,
                         const std::string& where = "constraint");

// A joint's index by name; an unknown name throws Error naming it and listing
// the skeleton's joints.
size_t joint_index(const Skeleton& skeleton, const std::string& name);

// --- path helpers ------------------------------------------------------------

// A dense path at constant speed (m/s) along a polyline of (x, z) points, one
// sample per frame from start_frame until the last point is reached;
// headings along the direction of travel (constraints.py path_from_polyline).
RootPath path_from_polyline(const std::vector<glm::dvec2>& points, double speed, int64_t start_frame, double fps,
                            bool with_heading = true);

// Mouse-style click points: linear interpolation at `speed` (as
// path_from_polyline), then smoothed with a centred moving average of
// 2 * smoothing_frames + 1 frames (the window shrinks at both ends, so the
// first and last points stay where they were clicked), headings along the
// smoothed path.
RootPath path_from_clicks(const std::vector<glm::dvec2>& points, double speed, int64_t start_frame, double fps,
                          size_t smoothing_frames = 4);

// Keyboard steering (paper section 4.2): from the root's ground position at
// frame start_frame - 1 and its current velocity (m/s, x and z), the velocity
// blends linearly to `target_velocity` over `blend_frames` frames and is
// integrated over `frames` frames from start_frame. Headings follow the
// velocity; while the speed is below 1e-3 m/s they keep `current_heading`
// (or the first later direction of travel; no headings if it never moves and
// no current heading is given).
RootPath path_from_velocity(const glm::dvec2& position, const glm::dvec2& current_velocity,
                            const glm::dvec2& target_velocity, int64_t start_frame, size_t frames, size_t blend_frames,
                            double fps, std::optional<double> current_heading = std::nullopt);

// World explicit features [M] of a pose (velocities and contacts 0) for a
// PoseKeyframe: world rotations and positions per joint (positions[0] = the
// root), heading psi of the character.
std::vector<double> pose_features(const FeatureLayout& layout, const std::vector<glm::mat3>& global_rotations,
                                  const std::vector<glm::vec3>& positions, double heading);

// --- timeline -------------------------------------------------------------------

class ConstraintTimeline {
 public:
  using Id = uint64_t;
  struct Entry {
    Id id = 0;
    Constraint constraint;
  };
  struct Split {              // ids by time relative to a window (constraints.py split_by_time)
    std::vector<Id> passed;   // entirely before the window start
    std::vector<Id> active;   // touching [start, start + horizon)
    std::vector<Id> waiting;  // entirely at or after start + horizon
  };

  explicit ConstraintTimeline(FeatureLayout layout);

  // Validates (Error, timeline unchanged) and appends; later entries override
  // earlier ones. Returns the new entry's id (never reused).
  Id add(Constraint constraint);
  bool remove(Id id);  // false when there is no such entry
  void clear();
  // Removes the constraints whose last frame is before `frame`; returns their ids.
  std::vector<Id> drop_passed(int64_t frame);

  const std::vector<Entry>& entries() const { return entries_; }
  const Constraint* find(Id id) const;
  size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }
  const FeatureLayout& layout() const { return layout_; }
  Split split(int64_t window_start, int64_t horizon_frames) const;
  // Changes on every add, remove, clear or drop (a planner's replan trigger).
  uint64_t revision() const { return revision_; }

 private:
  FeatureLayout layout_;
  std::vector<Entry> entries_;
  Id next_id_ = 1;
  uint64_t revision_ = 0;
};

// --- per-window goals ---------------------------------------------------------------

// Goal tensors of one window, normalized, model frame, patchified (float32).
struct WindowGoals {
  size_t window_tokens = 0;             // C
  size_t future_tokens = 0;             // F (may be 0)
  size_t goal_dim = 0;                  // P * M
  std::vector<float> window_goal;       // [C, goal_dim]
  std::vector<float> window_goal_mask;  // [C, goal_dim]
  std::vector<float> future_goal;       // [F, goal_dim]
  std::vector<float> future_goal_mask;  // [F, goal_dim]
  std::vector<float> future_mask;       // [F]: 1 where the token has a constrained entry
  bool any_window_constraint = false;
  // A dense root path and nothing else: the root's ground position is given on
  // at least half of the window's frames and every constrained entry, in the
  // window and the future, is a root position or heading (the sampler's
  // path_guidance_scale applies).
  bool root_path_only = false;

  // Any constrained entry in the window or the future (guidance: w_con used).
  bool has_constraints() const;
};

struct GoalSpec {
  const FeatureLayout* layout = nullptr;
  const Normalization* normalization = nullptr;  // feature statistics [M]
  size_t patch = 0;
  size_t window_tokens = 0;
  size_t future_limit_tokens = 0;
  // Fill the root's x and z between sparse root targets (waypoints, keyframe
  // roots): linear from offset_xz (the root of the frame before the window) to
  // the first target, then between consecutive targets. The model follows
  // dense root paths far better than isolated targets (docs/evaluation).
  bool interpolate_root = false;
  // Root speed limit (m/s; 0: none). The root's (x, z) goals are walked in
  // frame order from offset_xz, and a goal further from the previous one (or
  // from offset_xz) than this speed allows is pulled back toward it, so no
  // set of targets asks for a teleport: a waypoint too far for its time is
  // approached at this speed, and targets that disagree (a waypoint beside a
  // keyboard path) are joined at this speed. Applied after interpolate_root.
  double max_root_speed = 0.0;
  double fps = 0.0;  // frames per second (needed by max_root_speed)
};

// A speed no clip of the training data reaches (its fastest root moves at
// 5.1 m/s): the default root speed limit of rollouts and planners.
constexpr double kDefaultMaxRootSpeed = 6.0;

// Whether a constraint sets the root's ground position (x, z) at some frame:
// waypoints, paths, keyframes with their root, targets of the root joint's position.
bool constrains_root_position(const Constraint& constraint);

// constraints.py window_goals: rasterizes the frames [window_start,
// window_start + (C + future_limit) * P) in float64 (later constraints
// override earlier ones), subtracts offset_xz from the root x and z goals,
// normalizes the constrained entries ((g - mean) / std in float64, then
// float32), zeroes the rest, patchifies, and cuts the future after the last
// token with a constrained entry.
WindowGoals window_goals(const std::vector<Constraint>& constraints, int64_t window_start, const glm::dvec2& offset_xz,
                         const GoalSpec& spec);
WindowGoals window_goals(const ConstraintTimeline& timeline, int64_t window_start, const glm::dvec2& offset_xz,
                         const GoalSpec& spec);

}  // namespace ardy
