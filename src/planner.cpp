#include "planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "generation_cpu.hpp"
#include "joint_reach.hpp"
#include "kinematics.hpp"
#include "motion_filter.hpp"
#include "timeline.hpp"

namespace ardy {

namespace {

constexpr size_t kLogCapacity = 256;
constexpr double kPi = 3.14159265358979323846;
constexpr int64_t kAsap = std::numeric_limits<int64_t>::min();

// Smallest multiple of `patch` >= frame (frames may be negative).
int64_t token_ceil(int64_t frame, int64_t patch) {
  const int64_t q = frame / patch;
  const int64_t r = frame % patch;
  return (r > 0 ? q + 1 : q) * patch;
}

std::string number_text(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

void check_finite(const char* call, const char* field, double v) {
  if (!std::isfinite(v)) {
    throw Error(std::string(call) + ": " + field + " is " + number_text(v) + ", expected a finite number");
  }
}

float wrap_angle(float a) {
  const auto two_pi = static_cast<float>(2.0 * kPi);
  a = std::fmod(a + static_cast<float>(kPi), two_pi);
  if (a < 0.0f) a += two_pi;
  return a - static_cast<float>(kPi);
}

double steady_seconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

// Prefixes an Error's message with the public call that caused it.
template <typename F>
auto with_context(const char* call, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Cancelled&) {
    throw;
  } catch (const Error& e) {
    throw Error(std::string(call) + ": " + e.what());
  }
}

}  // namespace

const char* window_outcome_name(WindowOutcome outcome) {
  switch (outcome) {
    case WindowOutcome::published: return "published";
    case WindowOutcome::late: return "late";
    case WindowOutcome::cancelled: return "cancelled";
    case WindowOutcome::failed: return "failed";
  }
  return "unknown";
}

// Generated frames, immutable once published; shared by the frame queue
// (caller side) and nothing else.
struct Planner::FrameBlock {
  int64_t start = 0;
  size_t count = 0;
  uint64_t window_id = 0;
  std::vector<glm::vec3> root_position;    // [count]
  std::vector<float> heading;              // [count]
  std::vector<glm::quat> local_rotations;  // [count * J]
  std::vector<glm::vec3> positions;        // [count * J]
  std::vector<float> contacts;             // [count * c]
  // The window the frames came from (frame start + i is its row i): the
  // model's own frames for raw_frame_at, kept alive by the block, no copy.
  std::shared_ptr<const WindowResult> raw;
};

// A window's committed part and the rollout state before it (the rollback
// point of a splice inside it).
struct Planner::Segment {
  int64_t start = 0;
  size_t tokens = 0;
  uint64_t window_id = 0;
  Rollout before;
  std::shared_ptr<const WindowResult> result;
  std::vector<float> shown;  // the output filter's features of the frames (empty: filter off)
  std::vector<FootLockState> foot_states;  // after each frame (empty: no foot locking)
};

// What the commands have set: the worker's copy, applied to the rollout
// before every window.
struct Planner::MasterState {
  std::vector<PromptEvent> prompts;
  std::vector<std::pair<ConstraintId, Constraint>> constraints;
  std::optional<glm::dvec2> velocity;
  RolloutSettings settings;
};

// --- construction ---------------------------------------------------------------------

Planner::Planner(std::shared_ptr<const ModelPackage> package, PlannerConfig config)
    : package_(std::move(package)), config_(std::move(config)) {
  if (!package_) throw Error("Planner: no model package given");
  const ModelPackage& p = *package_;
  const TokenSizes& t = p.tokens();
  fps_ = p.fps();
  patch_ = static_cast<int64_t>(t.patch);
  joints_ = p.skeleton().joint_count();
  contacts_ = p.layout().contact_count();

  auto check_seconds = [](const char* field, double v, bool positive) {
    if (!std::isfinite(v) || v < 0.0 || (positive && v == 0.0) || v > 1e6) {
      throw Error(std::string("Planner config: ") + field + " is " + number_text(v) + ", expected a finite number " +
                  (positive ? "> 0" : ">= 0") + " (seconds)");
    }
  };
  check_seconds("history_seconds", config_.history_seconds, false);
  if (!std::isfinite(config_.max_root_speed) || config_.max_root_speed < 0.0) {
    throw Error("Planner config: max_root_speed is " + number_text(config_.max_root_speed) +
                ", expected a finite number >= 0 (m/s; 0: no limit)");
  }
  if (config_.future_seconds) check_seconds("future_seconds", *config_.future_seconds, false);
  check_seconds("initial_latency_seconds", config_.initial_latency_seconds, false);
  check_seconds("low_water_seconds", config_.low_water_seconds, false);
  check_seconds("keep_behind_seconds", config_.keep_behind_seconds, false);
  if (config_.velocity_blend_seconds) check_seconds("velocity_blend_seconds", *config_.velocity_blend_seconds, true);
  if (config_.velocity_path_seconds) check_seconds("velocity_path_seconds", *config_.velocity_path_seconds, true);
  if (!std::isfinite(config_.latency_margin) || config_.latency_margin < 1.0 || config_.latency_margin > 100.0) {
    throw Error("Planner config: latency_margin is " + number_text(config_.latency_margin) + ", expected 1..100");
  }
  if (config_.output_smoothing_frames && (!std::isfinite(*config_.output_smoothing_frames) ||
                                          *config_.output_smoothing_frames < 0.0 ||
                                          *config_.output_smoothing_frames > kMaxSmoothingFrames)) {
    throw Error("Planner config: output_smoothing_frames is " + number_text(*config_.output_smoothing_frames) +
                ", expected 0.." + number_text(kMaxSmoothingFrames) + " (frames; 0 turns the filter off)");
  }
  if (config_.latency_samples == 0) throw Error("Planner config: latency_samples must be at least 1");
  if (config_.min_buffer_frames > 100000) throw Error("Planner config: min_buffer_frames is too large");
  if (!config_.generator) {
    config_.generator = [](const std::shared_ptr<const ModelPackage>& pkg, const WindowInput& in,
                           const std::vector<float>& noise, const CancelCheck& cancel) {
      return generate_window(*pkg, in, noise, cancel);
    };
  }
  if (!config_.clock) config_.clock = steady_seconds;

  RolloutSettings s;
  s.steps = config_.steps;
  s.w_text = config_.w_text;
  s.w_con = config_.w_con;
  const auto tokens_of = [&](double seconds) {
    return static_cast<size_t>(std::llround(seconds * fps_ / static_cast<double>(t.patch)));
  };
  s.history_tokens = std::min(tokens_of(config_.history_seconds), t.max_history);
  if (config_.future_seconds) s.future_tokens = std::min(tokens_of(*config_.future_seconds), t.max_future);
  if (config_.decode_context_tokens > 0) s.decode_context_tokens = config_.decode_context_tokens;
  s.start_xz = config_.start_xz;
  s.interpolate_root = config_.interpolate_root;
  s.path_guidance_scale = config_.path_guidance_scale;
  s.text_only_guidance_scale = config_.text_only_guidance_scale;
  s.max_root_speed = config_.max_root_speed;
  s.seed = config_.seed;
  smoothing_frames_ = config_.output_smoothing_frames.value_or(package_->sampling_defaults().output_smoothing_frames);
  if (config_.foot_lock) {
    foot_locker_.emplace(p.skeleton(), p.layout(), p.contact_joints());
    if (!foot_locker_->available()) foot_locker_.reset();
  }
  rollout_ = with_context("Planner config", [&] { return std::make_unique<Rollout>(package_, s); });
  if (!config_.initial_history.empty()) {
    const size_t m = p.layout().feature_size;
    const size_t frames = config_.initial_history.size() / m;
    if (frames * m != config_.initial_history.size()) {
      throw Error("Planner config: initial_history has " + std::to_string(config_.initial_history.size()) +
                  " values, not a whole number of frames of " + std::to_string(m) + " features");
    }
    with_context("Planner config: initial_history", [&] {
      rollout_->seed_history(config_.initial_history, frames);
      return 0;
    });
    const size_t keep = std::min(frames, smoothing_radius(smoothing_frames_));
    initial_shown_.assign(config_.initial_history.end() - static_cast<std::ptrdiff_t>(keep * m),
                          config_.initial_history.end());
  }
  master_ = std::make_unique<MasterState>();
  master_->settings = s;
  last_good_ = std::make_unique<MasterState>(*master_);
  future_frames_.store(rollout_->config().future_tokens * t.patch);
  noise_ = NoiseGenerator(config_.seed ^ 0x9e3779b97f4a7c15ull);
  latency_estimate_.store(config_.initial_latency_seconds * config_.latency_margin);
  low_water_frames_.store(std::max<int64_t>(static_cast<int64_t>(std::ceil(config_.low_water_seconds * fps_)),
                                            latency_frames() + 2 + patch_));
  inbox_.reserve(16);
  if (config_.prompt) {
    with_context("Planner config: prompt", [&] { package_->text_encoder().normalize_prompt(*config_.prompt); });
    inbox_.push_back(PromptCommand{0, true, *config_.prompt});
  }
  for (size_t i = 0; i < config_.initial_prompts.size(); ++i) {
    const PromptEvent& event = config_.initial_prompts[i];
    const std::string where = "Planner config: initial_prompts[" + std::to_string(i) + "]";
    if (event.frame < 0) throw Error(where + ": frame is " + std::to_string(event.frame) + ", expected >= 0");
    if (event.text) with_context(where.c_str(), [&] { package_->text_encoder().normalize_prompt(*event.text); });
    inbox_.push_back(PromptCommand{event.frame, event.frame == 0, event.text});
  }
  for (size_t i = 0; i < config_.initial_constraints.size(); ++i) {
    validate_constraint(config_.initial_constraints[i], p.layout(),
                        "Planner config: initial_constraints[" + std::to_string(i) + "]");
    inbox_.push_back(AddConstraintCommand{next_constraint_id_.fetch_add(1), config_.initial_constraints[i]});
  }
  low_signal_ = true;  // the queue is empty: the first window is due
  worker_ = std::thread([this] { worker_main(); });
}

Planner::~Planner() {
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    stop_ = true;
  }
  stopping_.store(true);
  wake_.notify_all();
  idle_.notify_all();
  if (worker_.joinable()) worker_.join();
}

size_t Planner::joint_count() const { return joints_; }

double Planner::now() const { return config_.clock(); }

// --- caller side: clock and frames -------------------------------------------------------

int64_t Planner::playhead_frame() const {
  return static_cast<int64_t>(std::floor(playhead_.load(std::memory_order_acquire) * fps_ + 1e-9));
}

void Planner::advance(double delta) {
  if (!std::isfinite(delta) || delta < 0.0) {
    throw Error("advance: delta is " + number_text(delta) + " s, expected a finite number >= 0");
  }
  // Under the frame lock: the worker swaps frames in under it after checking
  // the playhead, so the playhead never passes frames that are being replaced
  // and is clamped to the frames that exist now.
  int64_t end = 0;
  double next = 0.0;
  {
    std::lock_guard<std::mutex> lock(frames_mutex_);
    const double current = playhead_.load(std::memory_order_relaxed);
    next = current;
    if (!spans_.empty()) {
      end = spans_.back().end;
      next = std::max(current, std::min(current + delta, static_cast<double>(end - 1) / fps_));
    }
    playhead_.store(next, std::memory_order_release);
    const double lost = current + delta - next;
    if (lost > 0.0) underrun_.store(underrun_.load(std::memory_order_relaxed) + lost, std::memory_order_relaxed);
  }
  const double ahead = static_cast<double>(end) - next * fps_;
  if (ahead < static_cast<double>(low_water_frames_.load(std::memory_order_relaxed))) {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    if (!low_signal_) {
      low_signal_ = true;
      wake_.notify_one();
    }
  }
}

double Planner::time() const { return playhead_.load(std::memory_order_acquire); }

double Planner::queued_seconds() const {
  const double ahead = static_cast<double>(frames_end_.load(std::memory_order_acquire)) / fps_ - time();
  return std::max(0.0, ahead);
}

void Planner::fill_frame(const FrameSpan& span, int64_t frame, Pose& out) const {
  const FrameBlock& b = *span.block;
  const auto i = static_cast<size_t>(frame - b.start);
  out.root_position = b.root_position[i];
  out.heading = b.heading[i];
  std::copy_n(b.local_rotations.begin() + static_cast<std::ptrdiff_t>(i * joints_), joints_,
              out.local_rotations.begin());
  std::copy_n(b.positions.begin() + static_cast<std::ptrdiff_t>(i * joints_), joints_, out.positions.begin());
  std::copy_n(b.contacts.begin() + static_cast<std::ptrdiff_t>(i * contacts_), contacts_, out.contacts.begin());
  out.window_id = b.window_id;
}

void Planner::size_pose(Pose& out) const {
  if (out.local_rotations.size() != joints_) out.local_rotations.resize(joints_);
  if (out.positions.size() != joints_) out.positions.resize(joints_);
  if (out.contacts.size() != contacts_) out.contacts.resize(contacts_);
}

bool Planner::sample(double t, Pose& out) const {
  size_pose(out);
  std::lock_guard<std::mutex> lock(frames_mutex_);
  if (spans_.empty()) return false;
  const int64_t first = spans_.front().begin;
  const int64_t last = spans_.back().end - 1;
  double f = std::isfinite(t) ? t * fps_ : static_cast<double>(first);
  f = std::min(std::max(f, static_cast<double>(first)), static_cast<double>(last));
  auto i0 = static_cast<int64_t>(std::floor(f));
  float a = static_cast<float>(f - static_cast<double>(i0));
  if (i0 >= last) {
    i0 = last;
    a = 0.0f;
  }
  const FrameSpan* s0 = nullptr;
  const FrameSpan* s1 = nullptr;
  for (const FrameSpan& s : spans_) {
    if (i0 >= s.begin && i0 < s.end) s0 = &s;
    if (i0 + 1 >= s.begin && i0 + 1 < s.end) s1 = &s;
  }
  if (!s0) return false;  // cannot happen: spans are contiguous
  fill_frame(*s0, i0, out);
  out.time = f / fps_;
  if (a <= 0.0f || !s1) return true;
  const FrameBlock& b = *s1->block;
  const auto i = static_cast<size_t>(i0 + 1 - b.start);
  out.root_position = glm::mix(out.root_position, b.root_position[i], a);
  out.heading = wrap_angle(out.heading + a * wrap_angle(b.heading[i] - out.heading));
  for (size_t j = 0; j < joints_; ++j) {
    out.local_rotations[j] = slerp_shortest(out.local_rotations[j], b.local_rotations[i * joints_ + j], a);
    out.positions[j] = glm::mix(out.positions[j], b.positions[i * joints_ + j], a);
  }
  for (size_t c = 0; c < contacts_; ++c) {
    out.contacts[c] += a * (b.contacts[i * contacts_ + c] - out.contacts[c]);
  }
  return true;
}

bool Planner::frame_at(int64_t frame, Pose& out) const { return find_frame(frame, out, false); }

bool Planner::raw_frame_at(int64_t frame, Pose& out) const { return find_frame(frame, out, true); }

bool Planner::find_frame(int64_t frame, Pose& out, bool raw) const {
  size_pose(out);
  std::lock_guard<std::mutex> lock(frames_mutex_);
  for (const FrameSpan& s : spans_) {
    if (frame >= s.begin && frame < s.end) {
      if (raw) {
        fill_raw_frame(s, frame, out);
      } else {
        fill_frame(s, frame, out);
      }
      out.time = static_cast<double>(frame) / fps_;
      return true;
    }
  }
  return false;
}

void Planner::fill_raw_frame(const FrameSpan& span, int64_t frame, Pose& out) const {
  const FrameBlock& b = *span.block;
  const WindowResult& raw = *b.raw;
  const FeatureLayout& layout = package_->layout();
  const auto i = static_cast<size_t>(frame - b.start);
  const float* row = raw.features.data() + i * layout.feature_size;
  const float* root = row + layout.root_position.start;
  out.root_position = glm::vec3(root[0], root[1], root[2]);
  out.heading = heading_angle(row[layout.heading.start], row[layout.heading.start + 1]);
  const glm::mat3* local = raw.motion.local_rotations_of(i);
  const glm::vec3* positions = raw.motion.positions_of(i);
  for (size_t j = 0; j < joints_; ++j) {
    out.local_rotations[j] = quat_from_matrix(local[j]);
    out.positions[j] = positions[j];
  }
  std::copy_n(row + layout.foot_contacts.start, contacts_, out.contacts.begin());
  out.window_id = b.window_id;
}

// --- caller side: commands -------------------------------------------------------------

int64_t Planner::frame_of(double time, const char* what) const {
  return with_context(what, [&] { return seconds_to_frame(time, fps_); });
}

void Planner::push(Command command, bool asap) {
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    inbox_.push_back(std::move(command));
    if (asap) asap_pending_.store(true, std::memory_order_relaxed);
  }
  wake_.notify_one();
}

void Planner::set_prompt(const std::string& text) {
  with_context("set_prompt", [&] { package_->text_encoder().normalize_prompt(text); });
  push(PromptCommand{playhead_frame(), true, text}, true);
}

void Planner::set_prompt_at(double time, const std::string& text) {
  const int64_t frame = frame_of(time, "set_prompt_at");
  with_context("set_prompt_at", [&] { package_->text_encoder().normalize_prompt(text); });
  const int64_t now_frame = playhead_frame();
  push(PromptCommand{std::max(frame, now_frame), frame <= now_frame, text}, frame <= now_frame);
}

void Planner::clear_prompt() { push(PromptCommand{playhead_frame(), true, std::nullopt}, true); }

void Planner::clear_prompt_at(double time) {
  const int64_t frame = frame_of(time, "clear_prompt_at");
  const int64_t now_frame = playhead_frame();
  push(PromptCommand{std::max(frame, now_frame), frame <= now_frame, std::nullopt}, frame <= now_frame);
}

void Planner::reset_prompts_at(double time, std::optional<std::string> text) {
  const int64_t frame = frame_of(time, "reset_prompts_at");
  if (text) with_context("reset_prompts_at", [&] { package_->text_encoder().normalize_prompt(*text); });
  const int64_t now_frame = playhead_frame();
  push(PromptCommand{std::max(frame, now_frame), frame <= now_frame, std::move(text), true}, true);
}

Planner::ConstraintId Planner::add_constraint(Constraint constraint) {
  validate_constraint(constraint, package_->layout(), std::string("add_constraint"));
  const ConstraintId id = next_constraint_id_.fetch_add(1);
  // A splice is asked for at once only when a queued window could see it.
  const auto [first, last] = constraint_frames(constraint);
  const int64_t horizon = frames_end_.load(std::memory_order_acquire) +
                          static_cast<int64_t>(rollout_future_frames_hint());
  const bool asap = first < horizon && last >= playhead_frame();
  push(AddConstraintCommand{id, std::move(constraint)}, asap);
  return id;
}

Planner::ConstraintId Planner::add_waypoint(double time, double x, double z, std::optional<double> heading) {
  RootWaypoint w;
  w.frame = frame_of(time, "add_waypoint");
  w.x = x;
  w.z = z;
  w.heading = heading;
  validate_constraint(w, package_->layout(), "add_waypoint");
  return add_constraint(std::move(w));
}

Planner::ConstraintId Planner::add_path(double start_time, const std::vector<glm::dvec2>& points, double speed,
                                        bool smooth) {
  const int64_t start = frame_of(start_time, "add_path");
  RootPath path = with_context("add_path", [&] {
    return smooth ? path_from_clicks(points, speed, start, fps_) : path_from_polyline(points, speed, start, fps_);
  });
  validate_constraint(path, package_->layout(), "add_path");
  return add_constraint(std::move(path));
}

Planner::ConstraintId Planner::add_path_frames(double start_time, std::vector<glm::dvec2> positions,
                                               std::vector<double> headings) {
  RootPath path;
  path.start_frame = frame_of(start_time, "add_path_frames");
  path.positions = std::move(positions);
  path.headings = std::move(headings);
  validate_constraint(path, package_->layout(), "add_path_frames");
  return add_constraint(std::move(path));
}

Planner::ConstraintId Planner::add_keyframe(double time, std::vector<double> features, bool include_root) {
  PoseKeyframe k;
  k.frame = frame_of(time, "add_keyframe");
  k.features = std::move(features);
  k.include_root = include_root;
  validate_constraint(k, package_->layout(), "add_keyframe");
  return add_constraint(std::move(k));
}

PoseKeyframe keyframe_from_pose(const ModelPackage& package, int64_t frame, const Pose& pose, bool include_root,
                                const char* what) {
  const Skeleton& skeleton = package.skeleton();
  const size_t joints = skeleton.joint_count();
  if (pose.local_rotations.size() != joints) {
    throw Error(std::string(what) + ": the pose has " + std::to_string(pose.local_rotations.size()) +
                " rotations, expected one per joint (" + std::to_string(joints) + ")");
  }
  check_finite(what, "root_position.x", pose.root_position.x);
  check_finite(what, "root_position.y", pose.root_position.y);
  check_finite(what, "root_position.z", pose.root_position.z);
  check_finite(what, "heading", pose.heading);
  std::vector<glm::mat3> local(joints);
  for (size_t j = 0; j < joints; ++j) {
    const glm::quat& q = pose.local_rotations[j];
    const float n = glm::length(q);
    if (!std::isfinite(n) || n < 1e-6f) {
      throw Error(std::string(what) + ": local_rotations[" + std::to_string(j) + "] (" + skeleton.name(j) +
                  ") is not a finite non-zero quaternion");
    }
    local[j] = matrix_from_quat(q / n);
  }
  const GlobalPose global = forward_kinematics(skeleton, pose.root_position, local);
  PoseKeyframe keyframe;
  keyframe.frame = frame;
  keyframe.features = with_context(what, [&] {
    return pose_features(package.layout(), global.rotations, global.positions, pose.heading);
  });
  keyframe.include_root = include_root;
  validate_constraint(keyframe, package.layout(), what);
  return keyframe;
}

JointTarget joint_target_from_spec(const ModelPackage& package, int64_t frame, const JointTargetSpec& spec,
                                   const char* what) {
  const size_t joint = with_context(what, [&] { return joint_index(package.skeleton(), spec.joint); });
  if (!spec.position && !spec.rotation) {
    throw Error(std::string(what) + ": joint '" + spec.joint + "' has neither a position nor a rotation");
  }
  std::optional<glm::dmat3> rotation;
  if (spec.rotation) {
    const glm::dquat& q = *spec.rotation;
    const double n = glm::length(q);
    if (!std::isfinite(n) || n < 1e-9) {
      throw Error(std::string(what) + ": rotation of joint '" + spec.joint + "' is not a finite non-zero quaternion");
    }
    rotation = glm::mat3_cast(q / n);
  }
  if (spec.position) {
    check_finite(what, "position.x", spec.position->x);
    check_finite(what, "position.y", spec.position->y);
    check_finite(what, "position.z", spec.position->z);
  }
  JointTarget target;
  if (spec.root_xz && spec.position) {
    check_finite(what, "root_xz.x", spec.root_xz->x);
    check_finite(what, "root_xz.z", spec.root_xz->y);
    target = JointTarget::from_world(frame, joint, *spec.position, *spec.root_xz, rotation);
  } else {
    target.frame = frame;
    target.joint = joint;
    target.position = spec.position;
    target.rotation = rotation;
  }
  validate_constraint(target, package.layout(), what);
  return target;
}

Planner::ConstraintId Planner::add_keyframe_pose(double time, const Pose& pose, bool include_root) {
  return add_constraint(keyframe_from_pose(*package_, frame_of(time, "add_keyframe_pose"), pose, include_root,
                                           "add_keyframe_pose"));
}

Planner::ConstraintId Planner::add_joint_target(const JointTargetSpec& spec) {
  return add_constraint(joint_target_from_spec(*package_, frame_of(spec.time, "add_joint_target"), spec,
                                               "add_joint_target"));
}

Planner::ConstraintId Planner::add_contact(double start_time, double end_time, const std::vector<std::string>& feet,
                                           double value) {
  FootContact c;
  c.start_frame = frame_of(start_time, "add_contact");
  c.end_frame = frame_of(end_time, "add_contact");
  check_finite("add_contact", "value", value);
  if (value < 0.0 || value > 1.0) throw Error("add_contact: value is " + number_text(value) + ", expected 0..1");
  c.value = value;
  const std::vector<std::string>& names = package_->contact_joints();
  for (const std::string& foot : feet) {
    const auto it = std::find(names.begin(), names.end(), foot);
    if (it == names.end()) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      throw Error("add_contact: unknown foot '" + foot + "' (the model's contact joints are " + list + ")");
    }
    c.feet.push_back(static_cast<size_t>(it - names.begin()));
  }
  validate_constraint(c, package_->layout(), "add_contact");
  return add_constraint(std::move(c));
}

void Planner::remove_constraint(ConstraintId id) { push(RemoveConstraintCommand{id}, true); }

void Planner::clear_constraints() { push(ClearConstraintsCommand{}, true); }

void Planner::set_target_velocity(double vx, double vz) {
  check_finite("set_target_velocity", "vx", vx);
  check_finite("set_target_velocity", "vz", vz);
  if (std::hypot(vx, vz) > 100.0) {
    throw Error("set_target_velocity: speed " + number_text(std::hypot(vx, vz)) + " m/s is above the 100 m/s limit");
  }
  push(VelocityCommand{glm::dvec2(vx, vz)}, true);
}

void Planner::clear_target_velocity() { push(VelocityCommand{std::nullopt}, true); }

void Planner::set_sampling(std::optional<size_t> steps, std::optional<float> w_text, std::optional<float> w_con,
                           std::optional<float> path_guidance_scale,
                           std::optional<float> text_only_guidance_scale) {
  const size_t n = package_->schedule().num_steps();
  if (steps && (*steps < 1 || *steps > n)) {
    throw Error("set_sampling: steps is " + std::to_string(*steps) + ", expected 1.." + std::to_string(n) +
                " (diffusion.num_steps of the package)");
  }
  if (w_text) check_finite("set_sampling", "w_text", *w_text);
  if (w_con) check_finite("set_sampling", "w_con", *w_con);
  if (path_guidance_scale && !path_guidance_scale_in_range(*path_guidance_scale)) {
    throw Error("set_sampling: path_guidance_scale is " + number_text(*path_guidance_scale) + ", expected (0, 1]");
  }
  if (text_only_guidance_scale && !text_only_guidance_scale_in_range(*text_only_guidance_scale)) {
    throw Error("set_sampling: text_only_guidance_scale is " + number_text(*text_only_guidance_scale) +
                ", expected (0, 4]");
  }
  push(SamplingCommand{steps, w_text, w_con, path_guidance_scale, text_only_guidance_scale}, false);
}

// --- reports ---------------------------------------------------------------------------

PlannerStats Planner::stats() const {
  PlannerStats s;
  {
    std::lock_guard<std::mutex> lock(report_mutex_);
    s = stats_;
  }
  s.latency_estimate_seconds = latency_estimate_.load();
  s.underrun_seconds = underrun_.load();
  s.playhead = time();
  s.queued_seconds = queued_seconds();
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    s.window_in_flight = busy_;
  }
  return s;
}

std::vector<WindowRecord> Planner::window_log() const {
  std::lock_guard<std::mutex> lock(report_mutex_);
  return std::vector<WindowRecord>(log_.begin(), log_.end());
}

std::vector<std::string> Planner::take_errors() {
  std::lock_guard<std::mutex> lock(report_mutex_);
  std::vector<std::string> out(std::make_move_iterator(errors_.begin()), std::make_move_iterator(errors_.end()));
  errors_.clear();
  return out;
}

bool Planner::pop_error(std::string& out) {
  std::lock_guard<std::mutex> lock(report_mutex_);
  if (errors_.empty()) return false;
  out = std::move(errors_.front());
  errors_.pop_front();
  return true;
}

std::string Planner::last_error() const {
  std::lock_guard<std::mutex> lock(report_mutex_);
  return last_error_;
}

bool Planner::wait_idle(double timeout_seconds) const {
  std::unique_lock<std::mutex> lock(inbox_mutex_);
  const auto idle = [&] { return stop_ || (inbox_.empty() && !busy_ && !due_ && !low_signal_); };
  if (!std::isfinite(timeout_seconds) || timeout_seconds < 0.0) timeout_seconds = 0.0;
  return idle_.wait_for(lock, std::chrono::duration<double>(timeout_seconds), idle) && !stop_;
}

void Planner::report_error(const std::string& message) {
  std::lock_guard<std::mutex> lock(report_mutex_);
  last_error_ = message;
  errors_.push_back(message);
  while (errors_.size() > std::max<size_t>(config_.max_errors, 1)) errors_.pop_front();
  ++stats_.errors;
}

void Planner::record(const WindowRecord& r) {
  std::lock_guard<std::mutex> lock(report_mutex_);
  log_.push_back(r);
  while (log_.size() > kLogCapacity) log_.pop_front();
  switch (r.outcome) {
    case WindowOutcome::published:
      ++stats_.windows_published;
      if (r.spliced) ++stats_.splices;
      stats_.buffer_frames = r.buffer_frames;
      break;
    case WindowOutcome::late: ++stats_.late_windows; break;
    case WindowOutcome::cancelled: ++stats_.cancelled_windows; break;
    case WindowOutcome::failed: ++stats_.failed_windows; break;
  }
  if (r.outcome == WindowOutcome::published || r.outcome == WindowOutcome::late) {
    stats_.last_latency_seconds = r.latency_seconds;
  }
}

// --- worker ----------------------------------------------------------------------------

size_t Planner::rollout_future_frames_hint() const {
  return future_frames_.load(std::memory_order_relaxed);
}

double Planner::latency_estimate() const { return latency_estimate_.load(std::memory_order_relaxed); }

int64_t Planner::latency_frames() const {
  return static_cast<int64_t>(std::ceil(latency_estimate() * fps_ - 1e-9));
}

int64_t Planner::earliest_splice() const {
  const int64_t ph = playhead_frame();
  const int64_t raw = std::max(ph + 2 + latency_frames(), ph + 1 + static_cast<int64_t>(config_.min_buffer_frames));
  return token_ceil(raw, patch_);
}

void Planner::worker_main() {
  const GenerationThreadScope counted;
  std::vector<Command> batch;
  batch.reserve(16);
  std::unique_lock<std::mutex> lock(inbox_mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || !inbox_.empty() || low_signal_ || due_; });
    if (stop_) break;
    batch.swap(inbox_);
    asap_pending_.store(false, std::memory_order_relaxed);
    low_signal_ = false;
    due_ = false;
    busy_ = true;
    lock.unlock();
    bool more = false;
    try {
      apply(batch);
      maintain();
      if (work_due()) {
        run_window();
        more = work_due();
      }
    } catch (const std::exception& e) {
      report_error(std::string("planner: ") + e.what());
    } catch (...) {
      report_error("planner: unknown failure on the worker thread");
    }
    batch.clear();
    lock.lock();
    due_ = more && !stop_;
    busy_ = false;
    idle_.notify_all();
  }
  busy_ = false;
  idle_.notify_all();
}

void Planner::request_splice(int64_t frame) {
  splice_request_ = splice_request_ ? std::min(*splice_request_, frame) : frame;
}

void Planner::apply(std::vector<Command>& commands) {
  for (Command& c : commands) {
    try {
      apply_one(c);
    } catch (const std::exception& e) {
      report_error(std::string("planner: a command could not be applied: ") + e.what());
    }
    ++pending_commands_;
    failures_in_a_row_ = 0;
  }
  if (!commands.empty()) {
    std::lock_guard<std::mutex> lock(report_mutex_);
    stats_.commands += commands.size();
  }
}

void Planner::apply_one(Command& command) {
  MasterState& m = *master_;
  const int64_t queue_end = rollout_->next_frame();
  const int64_t ph = playhead_frame();
  const auto horizon = queue_end + static_cast<int64_t>(rollout_->config().future_tokens) * patch_;
  const auto affects = [&](const Constraint& c) {
    const auto [first, last] = constraint_frames(c);
    return first < horizon && last >= ph;
  };
  if (auto* p = std::get_if<PromptCommand>(&command)) {
    if (p->drop_later) {
      m.prompts.erase(std::remove_if(m.prompts.begin(), m.prompts.end(),
                                     [&](const PromptEvent& event) { return event.frame > p->frame; }),
                      m.prompts.end());
    }
    m.prompts.push_back(PromptEvent{p->frame, std::move(p->text)});
    if (p->now) {
      request_splice(kAsap);
    } else {
      const int64_t boundary = token_ceil(p->frame, patch_);
      if (boundary < queue_end) request_splice(boundary);
      // Beyond the queue: the window that reaches it is cut there.
    }
  } else if (auto* a = std::get_if<AddConstraintCommand>(&command)) {
    if (affects(a->constraint)) request_splice(kAsap);
    m.constraints.emplace_back(a->id, std::move(a->constraint));
  } else if (auto* r = std::get_if<RemoveConstraintCommand>(&command)) {
    const auto it = std::find_if(m.constraints.begin(), m.constraints.end(),
                                 [&](const auto& entry) { return entry.first == r->id; });
    if (it != m.constraints.end()) {
      if (affects(it->second)) request_splice(kAsap);
      m.constraints.erase(it);
    }
  } else if (std::holds_alternative<ClearConstraintsCommand>(command)) {
    for (const auto& entry : m.constraints) {
      if (affects(entry.second)) request_splice(kAsap);
    }
    m.constraints.clear();
  } else if (auto* v = std::get_if<VelocityCommand>(&command)) {
    if (v->velocity != m.velocity) request_splice(kAsap);
    m.velocity = v->velocity;
  } else if (auto* s = std::get_if<SamplingCommand>(&command)) {
    if (s->steps) m.settings.steps = s->steps;
    if (s->w_text) m.settings.w_text = s->w_text;
    if (s->w_con) m.settings.w_con = s->w_con;
    if (s->path_guidance_scale) m.settings.path_guidance_scale = s->path_guidance_scale;
    if (s->text_only_guidance_scale) m.settings.text_only_guidance_scale = s->text_only_guidance_scale;
  }
}

// Drops what the playhead has left behind: frames older than
// keep_behind_seconds, segments no splice can reach, passed constraints and
// superseded prompt events.
void Planner::maintain() {
  const int64_t ph = playhead_frame();
  // Segments: a splice is always after ph + 1.
  while (segments_.size() > 1) {
    const Segment& s = segments_.front();
    if (s.start + static_cast<int64_t>(s.tokens) * patch_ > ph + 1) break;
    segments_.erase(segments_.begin());
  }
  // Frames.
  const int64_t keep_from = ph - static_cast<int64_t>(std::ceil(config_.keep_behind_seconds * fps_));
  if (!spans_.empty() && spans_.front().end <= keep_from) {
    std::vector<FrameSpan> next;
    next.reserve(spans_.size());
    for (const FrameSpan& s : spans_) {
      if (s.end > keep_from) next.push_back(s);
    }
    if (next.empty()) next.push_back(spans_.back());
    {
      std::lock_guard<std::mutex> lock(frames_mutex_);
      spans_.swap(next);
    }
  }
  // Constraints and prompts that no window can see any more.
  MasterState& m = *master_;
  m.constraints.erase(std::remove_if(m.constraints.begin(), m.constraints.end(),
                                     [&](const auto& e) { return constraint_frames(e.second).second < ph; }),
                      m.constraints.end());
  int64_t active = std::numeric_limits<int64_t>::min();
  size_t active_index = m.prompts.size();
  for (size_t i = 0; i < m.prompts.size(); ++i) {
    if (m.prompts[i].frame <= ph && m.prompts[i].frame >= active) {
      active = m.prompts[i].frame;
      active_index = i;
    }
  }
  if (active_index < m.prompts.size()) {
    std::vector<PromptEvent> kept;
    kept.reserve(m.prompts.size());
    for (size_t i = 0; i < m.prompts.size(); ++i) {
      if (i == active_index || m.prompts[i].frame > ph) kept.push_back(std::move(m.prompts[i]));
    }
    m.prompts = std::move(kept);
  }
}

bool Planner::work_due() const {
  if (failures_in_a_row_ >= 2) return false;  // wait for a new command
  if (splice_request_) return true;
  const double ahead = static_cast<double>(rollout_->next_frame()) - playhead_.load() * fps_;
  return ahead < static_cast<double>(low_water_frames_.load());
}

const Planner::Segment* Planner::segment_before(int64_t frame) const {
  for (auto it = segments_.rbegin(); it != segments_.rend(); ++it) {
    if (it->start < frame) return &*it;
  }
  return nullptr;
}

Rollout Planner::rollout_at(int64_t frame) const {
  for (const Segment& s : segments_) {
    const int64_t end = s.start + static_cast<int64_t>(s.tokens) * patch_;
    if (frame >= s.start && frame < end) {
      Rollout r = s.before;
      if (frame > s.start) r.commit(*s.result, static_cast<size_t>((frame - s.start) / patch_));
      return r;
    }
  }
  throw Error("planner: no committed window holds frame " + std::to_string(frame) + " (internal error)");
}

bool Planner::run_window() {
  const ModelPackage& p = *package_;
  const TokenSizes& t = p.tokens();
  const int64_t window_frames = static_cast<int64_t>(t.window_frames());
  const int64_t queue_end = rollout_->next_frame();
  const int64_t ph = playhead_frame();

  int64_t start = queue_end;
  bool splice = false;
  if (splice_request_) {
    const int64_t earliest = earliest_splice();
    start = std::max(*splice_request_, earliest);
    if (start < queue_end) {
      splice = true;
    } else {
      start = queue_end;
    }
  }

  WindowRecord rec;
  rec.id = next_window_id_++;
  rec.start_frame = start;
  rec.spliced = splice;
  rec.playhead_frame = ph;
  rec.buffer_frames = start - ph;
  rec.commands = pending_commands_;
  {
    std::lock_guard<std::mutex> lock(report_mutex_);
    ++stats_.windows_started;
  }

  const double t0 = now();
  try {
    const MasterState& m = *master_;
    Rollout work = splice ? rollout_at(start) : *rollout_;
    work.configure(m.settings);
    work.clear_prompts();
    for (const PromptEvent& e : m.prompts) work.add_prompt(e.frame, e.text);
    ConstraintTimeline& timeline = work.constraints();
    timeline.clear();
    for (const auto& entry : m.constraints) timeline.add(entry.second);
    const int64_t horizon_end = start + static_cast<int64_t>((t.window + work.config().future_tokens) * t.patch);
    const bool root_targets_ahead =
        std::any_of(m.constraints.begin(), m.constraints.end(), [&](const auto& entry) {
          const auto [first, last] = constraint_frames(entry.second);
          return constrains_root_position(entry.second) && last >= start && first < horizon_end;
        });
    if (m.velocity && !root_targets_ahead) {
      const glm::dvec2 position = work.next_offset();
      const glm::dvec2 velocity = work.last_root_velocity().value_or(glm::dvec2(0.0));
      std::optional<double> heading;
      if (const auto root = work.last_root()) heading = heading_angle((*root)[3], (*root)[4]);
      const auto frames = static_cast<size_t>(std::llround(
          config_.velocity_path_seconds ? *config_.velocity_path_seconds * fps_ : static_cast<double>(window_frames)));
      const auto blend = static_cast<size_t>(std::llround(
          config_.velocity_blend_seconds ? *config_.velocity_blend_seconds * fps_ : static_cast<double>(window_frames)));
      timeline.add(path_from_velocity(position, velocity, *m.velocity, start, std::max<size_t>(frames, 1),
                                      std::max<size_t>(blend, 1), fps_, heading));
    }
    Rollout before = work;
    const WindowInput in = work.prepare_window();
    rec.history_tokens = in.history_tokens;
    rec.prompt = in.prompt;
    const std::vector<float> noise = noise_.normal(t.window * t.token_dim);
    const bool append = !splice;
    const CancelCheck cancel = [this, start, append] {
      if (stopping_.load(std::memory_order_relaxed)) return true;
      if (append && config_.cancel_obsolete_windows && asap_pending_.load(std::memory_order_relaxed)) {
        return earliest_splice() < start;
      }
      return false;
    };
    auto result = std::make_shared<WindowResult>(config_.generator(package_, in, noise, cancel));
    const double latency = std::max(0.0, now() - t0);
    rec.latency_seconds = latency;
    latencies_.push_back(latency);
    while (latencies_.size() > config_.latency_samples) latencies_.pop_front();
    const double estimate = *std::max_element(latencies_.begin(), latencies_.end()) * config_.latency_margin;
    latency_estimate_.store(estimate);
    low_water_frames_.store(std::max<int64_t>(static_cast<int64_t>(std::ceil(config_.low_water_seconds * fps_)),
                                              latency_frames() + 2 + patch_));
    if (result->start_frame != start || result->frame_count != t.window_frames()) {
      throw Error("the window generator returned a window of " + std::to_string(result->frame_count) +
                  " frames starting at frame " + std::to_string(result->start_frame) + ", expected " +
                  std::to_string(t.window_frames()) + " frames at frame " + std::to_string(start));
    }
    // Cut the window at the first prompt boundary inside it, so that the
    // next window starts there with the new prompt.
    size_t tokens = t.window;
    for (const PromptEvent& e : m.prompts) {
      const int64_t b = token_ceil(e.frame, patch_);
      if (b > start && b < start + window_frames) tokens = std::min(tokens, static_cast<size_t>((b - start) / patch_));
    }
    work.commit(*result, tokens);
    if (!publish(start, splice, tokens, std::move(before), std::move(work), std::move(result), rec.id)) {
      // Late: the caller may have seen a frame at or after the splice.
      rec.outcome = WindowOutcome::late;
      record(rec);
      return false;
    }
    rec.frames = tokens * t.patch;
    splice_request_.reset();
    pending_commands_ = 0;
    failures_in_a_row_ = 0;
    *last_good_ = *master_;
    rec.outcome = WindowOutcome::published;
    record(rec);
    return true;
  } catch (const Cancelled&) {
    rec.outcome = WindowOutcome::cancelled;
    rec.latency_seconds = std::max(0.0, now() - t0);
    record(rec);
    return false;
  } catch (const std::exception& e) {
    rec.outcome = WindowOutcome::failed;
    rec.latency_seconds = std::max(0.0, now() - t0);
    record(rec);
    ++failures_in_a_row_;
    const bool had_commands = pending_commands_ > 0;
    *master_ = *last_good_;
    splice_request_.reset();
    pending_commands_ = 0;
    report_error("planner: the window at frame " + std::to_string(start) + " failed: " + e.what() +
                 (had_commands ? " (the commands since the last good window were dropped)" : ""));
    return false;
  }
}

bool Planner::publish(int64_t start, bool splice, size_t tokens, Rollout before, Rollout after,
                      std::shared_ptr<const WindowResult> result, uint64_t window_id) {
  const ModelPackage& p = *package_;
  const FeatureLayout& layout = p.layout();
  const size_t m = layout.feature_size;
  const size_t count = tokens * static_cast<size_t>(patch_);

  // The output filter (motion_filter.hpp) on what is shown; the rollout keeps
  // the raw frames. Its left context: the frames shown just before `start`.
  const float* shown = result->features.data();
  const Motion* motion = &result->motion;
  std::vector<float> filtered;
  Motion filtered_motion;
  if (smoothing_radius(smoothing_frames_) > 0) {
    const float* context = nullptr;
    size_t context_frames = 0;
    if (const Segment* before_start = segment_before(start)) {
      context = before_start->shown.empty() ? before_start->result->features.data() : before_start->shown.data();
      context_frames = std::min(static_cast<size_t>(start - before_start->start), before_start->result->frame_count);
    }
    if (!context && start == 0 && !initial_shown_.empty()) {
      context = initial_shown_.data();
      context_frames = initial_shown_.size() / m;
    }
    filtered = smooth_features(layout, context, context_frames, shown, count, smoothing_frames_);
    features_to_motion(p.skeleton(), layout, filtered.data(), count, filtered_motion);
    shown = filtered.data();
    motion = &filtered_motion;
  }

  // Foot locking (foot_lock.hpp) on what is shown, from the state of the
  // frame before `start`.
  // The steps below change the shown motion: a copy of the model's first.
  const auto writable_motion = [&] {
    if (motion != &filtered_motion) {
      const size_t values = count * joints_;
      filtered_motion.frame_count = count;
      filtered_motion.joint_count = joints_;
      filtered_motion.global_rotations.assign(motion->global_rotations.begin(),
                                              motion->global_rotations.begin() + static_cast<std::ptrdiff_t>(values));
      filtered_motion.local_rotations.assign(motion->local_rotations.begin(),
                                             motion->local_rotations.begin() + static_cast<std::ptrdiff_t>(values));
      filtered_motion.positions.assign(motion->positions.begin(),
                                       motion->positions.begin() + static_cast<std::ptrdiff_t>(values));
      motion = &filtered_motion;
    }
  };
  std::vector<FootLockState> foot_states;
  if (foot_locker_) {
    writable_motion();
    FootLockState state;
    if (const Segment* before_start = segment_before(start)) {
      const auto at = static_cast<size_t>(start - 1 - before_start->start);
      if (at < before_start->foot_states.size()) state = before_start->foot_states[at];
    }
    const float* goal_mask = result->goal_mask.empty() ? nullptr : result->goal_mask.data();
    foot_locker_->apply(shown, filtered_motion, state, &foot_states, goal_mask, &result->motion);
  }

  // Joint targets reached by IK and turned toward (joint_reach.hpp) on what is shown.
  if (config_.joint_reach) {
    std::vector<JointTarget> targets;
    for (const auto& entry : master_->constraints) {
      const auto* target = std::get_if<JointTarget>(&entry.second);
      if (target && (target->position || target->rotation) && target->frame + kReachFadeFrames >= start &&
          target->frame - kReachFadeFrames < start + static_cast<int64_t>(count)) {
        targets.push_back(*target);
      }
    }
    if (!targets.empty()) {
      writable_motion();
      JointReach(p.skeleton()).apply(start, filtered_motion, targets);
    }
  }

  auto block = std::make_shared<FrameBlock>();
  block->start = start;
  block->count = count;
  block->window_id = window_id;
  block->raw = result;
  block->root_position.resize(count);
  block->heading.resize(count);
  block->local_rotations.resize(count * joints_);
  block->positions.resize(count * joints_);
  block->contacts.resize(count * contacts_);
  for (size_t f = 0; f < count; ++f) {
    const float* row = shown + f * m;
    const float* root = row + layout.root_position.start;
    block->root_position[f] = glm::vec3(root[0], root[1], root[2]);
    const float* h = row + layout.heading.start;
    block->heading[f] = heading_angle(h[0], h[1]);
    const float* c = row + layout.foot_contacts.start;
    std::copy(c, c + contacts_, block->contacts.begin() + static_cast<std::ptrdiff_t>(f * contacts_));
    const glm::mat3* local = motion->local_rotations_of(f);
    const glm::vec3* pos = motion->positions_of(f);
    for (size_t j = 0; j < joints_; ++j) {
      block->local_rotations[f * joints_ + j] = quat_from_matrix(local[j]);
      block->positions[f * joints_ + j] = pos[j];
    }
  }

  // Frames: everything before the splice stays, the new frames replace the
  // rest. The caller moves the playhead before it samples under the frame
  // lock, so checking the playhead under that lock sees every sample made so
  // far: a splice the playhead has reached is refused, never half applied.
  std::vector<FrameSpan> next;
  next.reserve(spans_.size() + 1);
  for (const FrameSpan& s : spans_) {
    if (s.begin >= start) continue;
    FrameSpan kept = s;
    kept.end = std::min(kept.end, start);
    next.push_back(std::move(kept));
  }
  next.push_back(FrameSpan{std::move(block), start, start + static_cast<int64_t>(count)});
  {
    std::lock_guard<std::mutex> lock(frames_mutex_);
    if (splice && playhead_frame() + 1 >= start) return false;
    spans_.swap(next);
    frames_end_.store(start + static_cast<int64_t>(count), std::memory_order_release);
  }

  // Segments: cut at the splice, then the new one.
  while (!segments_.empty() && segments_.back().start >= start) segments_.pop_back();
  if (!segments_.empty()) {
    Segment& last = segments_.back();
    const int64_t end = last.start + static_cast<int64_t>(last.tokens) * patch_;
    if (end > start) last.tokens = static_cast<size_t>((start - last.start) / patch_);
  }
  segments_.push_back(Segment{start, tokens, window_id, std::move(before), std::move(result), std::move(filtered),
                              std::move(foot_states)});
  *rollout_ = std::move(after);
  return true;
}

}  // namespace ardy
