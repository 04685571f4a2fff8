#pragma once

// Motion made ahead of time from a timeline known in full (a cut-scene, a
// bake, the CLI): a Planner driven to the end as fast as it can generate, its
// frames read as they are published. Nothing changes while it runs, so no
// window is spliced and the frames are exactly what a game's planner with
// the same config shows (output filter, foot lock and joint reach included):
// the game, the editor's bake and ardy-generate share this one path.

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "package.hpp"
#include "planner.hpp"

namespace ardy {

struct OfflineMotion {
  double fps = 0.0;
  std::vector<Pose> frames;           // model frames 0 .. N-1
  std::vector<WindowRecord> windows;  // the published windows that made them, in order
  double seconds() const { return fps > 0.0 ? static_cast<double>(frames.size()) / fps : 0.0; }
};

// Told the fraction done (0..1) after each window; returning false stops the
// generation (Error "cancelled").
using OfflineProgress = std::function<bool(double fraction)>;

// `seconds` of motion (rounded to whole frames, at least one) from `config`
// (its prompt, initial_prompts and initial_constraints: the timeline). Error
// for a bad config or seconds outside (0, 3600], a window that fails, or a
// cancel.
OfflineMotion generate_offline(std::shared_ptr<const ModelPackage> package, PlannerConfig config, double seconds,
                               const OfflineProgress& progress = {});

// The pose at `time` seconds, between frames as Planner::sample interpolates
// (positions linear, rotations slerp, heading the short way), clamped to the
// motion. False for an empty motion.
bool sample_offline(const OfflineMotion& motion, double time, Pose& out);

}  // namespace ardy
