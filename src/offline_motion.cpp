#include "offline_motion.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "kinematics.hpp"

namespace ardy {

namespace {

// A window waits this long at most; a planner that makes no frame in that
// time has stopped (its errors say why).
constexpr double kStallSeconds = 120.0;

float wrapped(float angle) { return std::remainder(angle, 6.2831853071795864769f); }

}  // namespace

OfflineMotion generate_offline(std::shared_ptr<const ModelPackage> package, PlannerConfig config, double seconds,
                               const OfflineProgress& progress) {
  if (!package) throw Error("generate_offline: no model package given");
  if (!std::isfinite(seconds) || seconds <= 0.0 || seconds > 3600.0) {
    throw Error("generate_offline: seconds is " + std::to_string(seconds) + ", expected more than 0 and at most 3600");
  }
  OfflineMotion motion;
  motion.fps = package->fps();
  const auto wanted = static_cast<int64_t>(std::max<long long>(1, std::llround(seconds * motion.fps)));
  // Frames are read as soon as they exist and the playhead follows, so the
  // queue stays short however long the motion is.
  config.low_water_seconds = std::max(config.low_water_seconds, 4.0);
  Planner planner(std::move(package), std::move(config));
  motion.frames.reserve(static_cast<size_t>(wanted));
  Pose pose;
  uint64_t last_window = 0;
  auto last_progress = std::chrono::steady_clock::now();
  while (static_cast<int64_t>(motion.frames.size()) < wanted) {
    const bool idle = planner.wait_idle(0.05);
    std::string error;
    if (planner.pop_error(error)) throw Error("generate_offline: " + error);
    const size_t before = motion.frames.size();
    while (static_cast<int64_t>(motion.frames.size()) < wanted &&
           planner.frame_at(static_cast<int64_t>(motion.frames.size()), pose)) {
      motion.frames.push_back(pose);
    }
    for (const WindowRecord& record : planner.window_log()) {
      if (record.id > last_window && record.outcome == WindowOutcome::published) {
        last_window = record.id;
        if (record.start_frame < wanted) motion.windows.push_back(record);
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (motion.frames.size() > before) {
      last_progress = now;
      planner.advance(std::max(0.0, static_cast<double>(motion.frames.size() - 1) / motion.fps - planner.time()));
      if (progress && !progress(static_cast<double>(motion.frames.size()) / static_cast<double>(wanted))) {
        throw Error("generate_offline: cancelled");
      }
    } else if (idle && std::chrono::duration<double>(now - last_progress).count() > kStallSeconds) {
      throw Error("generate_offline: the planner made no frame for " + std::to_string(int(kStallSeconds)) + " s");
    }
  }
  return motion;
}

bool sample_offline(const OfflineMotion& motion, double time, Pose& out) {
  if (motion.frames.empty()) return false;
  const double last = static_cast<double>(motion.frames.size() - 1);
  const double position = std::clamp(std::isfinite(time) ? time * motion.fps : 0.0, 0.0, last);
  const auto index = static_cast<size_t>(std::floor(position));
  const float blend = static_cast<float>(position - static_cast<double>(index));
  out = motion.frames[index];
  out.time = position / motion.fps;
  if (blend <= 0.0f || index + 1 >= motion.frames.size()) return true;
  const Pose& next = motion.frames[index + 1];
  out.root_position = glm::mix(out.root_position, next.root_position, blend);
  out.heading = wrapped(out.heading + blend * wrapped(next.heading - out.heading));
  for (size_t j = 0; j < out.local_rotations.size(); ++j) {
    out.local_rotations[j] = slerp_shortest(out.local_rotations[j], next.local_rotations[j], blend);
    out.positions[j] = glm::mix(out.positions[j], next.positions[j], blend);
  }
  for (size_t c = 0; c < out.contacts.size(); ++c) out.contacts[c] += blend * (next.contacts[c] - out.contacts[c]);
  return true;
}

}  // namespace ardy
