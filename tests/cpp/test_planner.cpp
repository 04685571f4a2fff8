// Planner: the streaming loop on its worker thread (design.md section 8).
// A "model double" wraps the window generation: the real generate_window on
// the tiny package or a smooth stand-in (an "ideal model" that continues the
// committed history exactly, so a wrong splice shows as a jump), with an
// artificial delay, a fake latency on an injected clock, a gate that holds a
// window in flight, and fault injection. Nothing here asserts a wall-clock
// time: latencies are fake or measured on a virtual game clock, and
// promptness is counted in model calls.

#include <catch_amalgamated.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "kinematics.hpp"
#include "planner.hpp"
#include "support/error_message.hpp"
#include "support/goldens.hpp"

using ardy::Planner;
using ardy::PlannerConfig;
using ardy::Pose;
using ardy::WindowInput;
using ardy::WindowOutcome;
using ardy::WindowRecord;
using ardy::WindowResult;
using ardy_test::error_message;
using ardy_test::shipped_package;
using ardy_test::tiny_package;
using Catch::Matchers::ContainsSubstring;

namespace {

constexpr double kFps = 20.0;
constexpr int64_t kPatch = 4;

int64_t token_ceil(int64_t f) { return (f + kPatch - 1) / kPatch * kPatch; }

// The smooth double's fastest turn: 180 degrees a second.
constexpr double kMaxTurnPerFrame = M_PI / kFps;

// The smooth stand-in for a trained model: continues the last history frame
// with its velocity, blending to a velocity chosen by the prompt (turned by
// 90 degrees when the window has constraints); the whole body turns with the
// heading. Reads the history exactly as the real model gets it (normalized,
// re-centred tokens), so a wrong rollback or offset makes a visible jump.
WindowResult smooth_window(const ardy::ModelPackage& p, const WindowInput& in) {
  const ardy::TokenSizes& t = p.tokens();
  const ardy::FeatureLayout& layout = p.layout();
  const ardy::Normalization& norm = p.feature_normalization();
  const size_t m = layout.feature_size, g = t.window_frames(), d = t.token_dim, rs = layout.root_size();
  const auto& mean = norm.mean();
  const auto& stddev = norm.stddev();
  const size_t r0 = layout.root().start;
  auto world_root = [&](size_t token, size_t frame, size_t r) {
    const float v = in.history[token * d + frame * rs + r] * stddev[r0 + r] + mean[r0 + r];
    if (r == 0) return double(v) + in.offset.x;
    if (r == 2) return double(v) + in.offset.y;
    return double(v);
  };
  glm::dvec2 pos = in.offset;
  glm::dvec2 vel(0.0);
  double psi = 0.0;
  if (in.history_tokens > 0) {
    const size_t h = in.history_tokens - 1;
    const size_t last = t.patch - 1;
    pos = glm::dvec2(world_root(h, last, 0), world_root(h, last, 2));
    vel = (pos - glm::dvec2(world_root(h, last - 1, 0), world_root(h, last - 1, 2))) * p.fps();
    psi = std::atan2(world_root(h, last, 4), world_root(h, last, 3));
  }
  glm::dvec2 target(0.0);
  const std::string prompt = in.prompt.value_or("");
  if (prompt.find("walk") != std::string::npos) target = {0.0, 1.2};
  if (prompt.find("run") != std::string::npos) target = {0.0, 3.0};
  if (prompt.find("turn") != std::string::npos) target = {1.5, 0.0};
  if (in.goals.has_constraints()) target = glm::dvec2(target.y, -target.x) + glm::dvec2(0.5, 0.0);

  WindowResult out;
  out.start_frame = in.start_frame;
  out.offset = in.offset;
  out.history_tokens = in.history_tokens;
  out.prompt = in.prompt;
  out.frame_count = g;
  out.features.assign(g * m, 0.0f);
  out.tokens.assign(t.window * d, 0.0f);
  for (size_t f = 0; f < g; ++f) {
    const double a = double(f + 1) / double(g);
    const glm::dvec2 v = vel + (target - vel) * a;
    pos += v / p.fps();
    // The heading turns toward the velocity at a bounded rate, as a body
    // does: from rest a sideways target must not snap it round (a jump of
    // the double's own, not the planner's).
    if (glm::length(v) > 1e-3) {
      const double turn = std::remainder(std::atan2(v.x, v.y) - psi, 2.0 * M_PI);
      psi += std::clamp(turn, -kMaxTurnPerFrame, kMaxTurnPerFrame);
    }
    float* row = out.features.data() + f * m;
    row[layout.root_position.start + 0] = float(pos.x);
    row[layout.root_position.start + 1] = 0.9f;
    row[layout.root_position.start + 2] = float(pos.y);
    row[layout.heading.start + 0] = float(std::cos(psi));
    row[layout.heading.start + 1] = float(std::sin(psi));
    const glm::mat3 r = ardy::heading_rotation(float(psi));
    for (size_t j = 0; j < layout.joint_count; ++j) ardy::rotation_to_6d(r, row + layout.rotation_6d_of(j).start);
    row[layout.foot_contacts.start] = (f / 8) % 2 ? 1.0f : 0.0f;
    const size_t k = f / t.patch, pp = f % t.patch;
    for (size_t rr = 0; rr < rs; ++rr) {
      double v2 = row[r0 + rr];
      if (rr == 0) v2 -= in.offset.x;
      if (rr == 2) v2 -= in.offset.y;
      out.tokens[k * d + pp * rs + rr] = float((v2 - mean[r0 + rr]) / stddev[r0 + rr]);
    }
  }
  ardy::features_to_motion(p.skeleton(), layout, out.features.data(), g, out.motion);
  return out;
}

// Wraps the window generation for tests.
class ModelDouble {
 public:
  enum class Kind { real, smooth };
  explicit ModelDouble(Kind kind = Kind::real) : kind_(kind) {}

  std::atomic<double> clock{0.0};       // the planner's clock when fake_clock() is used
  std::atomic<double> fake_latency{0.0};  // added to `clock` by every window
  std::atomic<int> delay_ms{0};         // real sleep before every model call (a slow model)
  std::atomic<int> windows{0};          // windows asked for
  std::atomic<int> model_calls{0};      // cancel checks (one before every denoiser/decoder call)
  std::atomic<bool> saw_cancel{false};
  std::atomic<int> in_flight{0};        // windows inside the generator now
  std::string fail_on_prompt;           // the window throws for this prompt (set before use)
  std::function<void()> on_window;      // runs on the worker inside every window (set before use)

  PlannerConfig config() {
    PlannerConfig c;
    c.generator = [this](const std::shared_ptr<const ardy::ModelPackage>& p, const WindowInput& in,
                         const std::vector<float>& noise,
                         const ardy::CancelCheck& cancel) { return generate(*p, in, noise, cancel); };
    return c;
  }
  PlannerConfig fake_clock_config() {
    PlannerConfig c = config();
    c.clock = [this] { return clock.load(); };
    return c;
  }

  void close_gate() {
    std::lock_guard<std::mutex> lock(mutex_);
    gate_closed_ = true;
  }
  void open_gate() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      gate_closed_ = false;
    }
    cv_.notify_all();
  }
  // Waits until `count` windows have entered the generator (test thread).
  bool wait_entered(int count) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, std::chrono::seconds(60), [&] { return entered_ >= count; });
  }
  std::vector<WindowInput> inputs() {
    std::lock_guard<std::mutex> lock(mutex_);
    return inputs_;
  }

 private:
  WindowResult generate(const ardy::ModelPackage& p, const WindowInput& in, const std::vector<float>& noise,
                        const ardy::CancelCheck& cancel) {
    ++windows;
    ++in_flight;
    struct Leave {
      std::atomic<int>& count;
      ~Leave() { --count; }
    } leave{in_flight};
    {
      std::unique_lock<std::mutex> lock(mutex_);
      inputs_.push_back(in);
      ++entered_;
      cv_.notify_all();
      while (gate_closed_) {
        if (cancel()) {
          saw_cancel = true;
          throw ardy::Cancelled();
        }
        cv_.wait_for(lock, std::chrono::milliseconds(1));
      }
    }
    if (on_window) on_window();
    if (!fail_on_prompt.empty() && in.prompt == fail_on_prompt) {
      throw ardy::Error("model double refuses the prompt '" + fail_on_prompt + "'");
    }
    const ardy::CancelCheck slow = [this, &cancel] {
      ++model_calls;
      const int ms = delay_ms.load();
      if (ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(ms));
      const bool stop = cancel();
      if (stop) saw_cancel = true;
      return stop;
    };
    WindowResult out;
    if (kind_ == Kind::real) {
      out = ardy::generate_window(p, in, noise, slow);
    } else {
      if (slow()) throw ardy::Cancelled();
      out = smooth_window(p, in);
    }
    double c = clock.load();
    while (!clock.compare_exchange_weak(c, c + fake_latency.load())) {
    }
    return out;
  }

  Kind kind_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool gate_closed_ = false;
  int entered_ = 0;
  std::vector<WindowInput> inputs_;
};

// One model frame, as the caller saw it.
struct FrameCopy {
  glm::vec3 root{0.0f};
  float heading = 0.0f;
  std::vector<glm::quat> rotations;
  std::vector<glm::vec3> positions;
  std::vector<float> contacts;
  uint64_t window = 0;

  explicit FrameCopy(const Pose& p)
      : root(p.root_position), heading(p.heading), rotations(p.local_rotations), positions(p.positions),
        contacts(p.contacts), window(p.window_id) {}
  bool operator==(const FrameCopy& o) const {
    return root == o.root && heading == o.heading && rotations == o.rotations && positions == o.positions &&
           contacts == o.contacts && window == o.window;
  }
};

std::map<int64_t, FrameCopy> queued_frames(const Planner& planner, int64_t from, int64_t to) {
  std::map<int64_t, FrameCopy> out;
  Pose pose;
  for (int64_t f = from; f < to; ++f) {
    if (planner.frame_at(f, pose)) out.emplace(f, FrameCopy(pose));
  }
  return out;
}

// Records every model frame the playhead makes visible (floor and floor + 1)
// and checks that a visible frame never changes afterwards.
class PlaybackRecorder {
 public:
  void observe(const Planner& planner) {
    const auto f0 = static_cast<int64_t>(std::floor(planner.time() * kFps + 1e-9));
    for (int64_t f = f0; f <= f0 + 1; ++f) {
      if (!planner.frame_at(f, pose_)) continue;
      const FrameCopy copy(pose_);
      const auto it = played_.find(f);
      if (it == played_.end()) {
        played_.emplace(f, copy);
      } else if (!(it->second == copy)) {
        ++changed_;
      }
    }
  }
  int changed() const { return changed_; }
  const std::map<int64_t, FrameCopy>& played() const { return played_; }

  // Largest per-frame joint displacement (root included) between consecutive
  // played frames from different windows and from the same window.
  struct Jumps {
    double across = 0.0;
    double within = 0.0;
    double root = 0.0;  // largest root (x, z) step anywhere
    int splices = 0;
  };
  Jumps jumps() const {
    Jumps j;
    for (auto it = played_.begin(); it != played_.end(); ++it) {
      const auto next = std::next(it);
      if (next == played_.end() || next->first != it->first + 1) continue;
      double m = glm::length(next->second.root - it->second.root);
      const glm::vec3 ground = next->second.root - it->second.root;
      j.root = std::max(j.root, double(std::hypot(ground.x, ground.z)));
      for (size_t k = 0; k < it->second.positions.size(); ++k) {
        m = std::max(m, double(glm::length(next->second.positions[k] - it->second.positions[k])));
      }
      if (next->second.window != it->second.window) {
        j.across = std::max(j.across, m);
        ++j.splices;
      } else {
        j.within = std::max(j.within, m);
      }
    }
    return j;
  }

 private:
  Pose pose_;
  std::map<int64_t, FrameCopy> played_;
  int changed_ = 0;
};

std::vector<WindowRecord> published(const Planner& planner) {
  std::vector<WindowRecord> out;
  for (const WindowRecord& r : planner.window_log()) {
    if (r.outcome == WindowOutcome::published) out.push_back(r);
  }
  return out;
}

template <typename Pred>
bool eventually(Pred pred) {
  for (int i = 0; i < 60000; ++i) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return false;
}

}  // namespace

// --- streaming ----------------------------------------------------------------------------

TEST_CASE("the planner streams model frames and interpolates between them", "[planner]") {
  ModelDouble model;
  Planner planner(tiny_package(), model.fake_clock_config());
  REQUIRE(planner.wait_idle());
  REQUIRE(planner.joint_count() == 21);
  const auto log = published(planner);
  REQUIRE(log.size() == 1);
  CHECK(log[0].start_frame == 0);
  CHECK(log[0].frames == 40);
  CHECK(!log[0].spliced);
  CHECK(log[0].history_tokens == 0);

  Pose pose;
  REQUIRE(planner.sample_current(pose));
  CHECK(pose.local_rotations.size() == 21);
  CHECK(pose.positions.size() == 21);
  CHECK(pose.contacts.size() == 4);
  CHECK(pose.root_position == pose.positions[0]);

  // Between frames 5 and 6: positions linear, rotations slerp, heading along the short arc.
  Pose a, b;
  REQUIRE(planner.frame_at(5, a));
  REQUIRE(planner.frame_at(6, b));
  REQUIRE(planner.sample(5.25 / kFps, pose));
  for (size_t j = 0; j < 21; ++j) {
    const glm::vec3 expected = glm::mix(a.positions[j], b.positions[j], 0.25f);
    CHECK(glm::length(pose.positions[j] - expected) < 1e-5f);
    const glm::quat q = ardy::slerp_shortest(a.local_rotations[j], b.local_rotations[j], 0.25f);
    CHECK(std::fabs(std::fabs(glm::dot(q, pose.local_rotations[j])) - 1.0f) < 1e-5f);
  }
  CHECK(glm::length(pose.root_position - glm::mix(a.root_position, b.root_position, 0.25f)) < 1e-5f);
  // Outside the queue: clamped to its ends.
  REQUIRE(planner.sample(-5.0, pose));
  REQUIRE(planner.frame_at(0, a));
  CHECK(pose.positions == a.positions);
  REQUIRE(planner.sample(1e6, pose));
  REQUIRE(planner.frame_at(39, a));
  CHECK(pose.positions == a.positions);
  CHECK_FALSE(planner.frame_at(40, a));

  // Playing on appends windows whenever less than the low-water mark is queued.
  for (int i = 0; i < 50; ++i) {
    planner.advance(0.1);
    REQUIRE(planner.wait_idle());
    CHECK(planner.queued_seconds() >= 1.0 - 1e-9);
  }
  CHECK(planner.time() == Catch::Approx(5.0));
  const auto later = published(planner);
  CHECK(later.size() >= 3);
  for (size_t i = 1; i < later.size(); ++i) {
    CHECK(later[i].start_frame == later[i - 1].start_frame + 40);
    CHECK(!later[i].spliced);
  }
  CHECK(later.back().history_tokens == tiny_package()->tokens().max_history);
  CHECK(planner.take_errors().empty());
  // Frames far behind the playhead are dropped (keep_behind_seconds = 1).
  CHECK_FALSE(planner.frame_at(0, a));
  CHECK(planner.frame_at(80, a));
}

TEST_CASE("a replan keeps the buffered frames bit-identical and starts after the measured latency", "[planner]") {
  ModelDouble model;
  model.fake_latency = 0.3;  // seconds on the planner's clock, per window
  PlannerConfig config = model.fake_clock_config();
  config.latency_margin = 1.0;
  config.initial_latency_seconds = 0.3;
  Planner planner(tiny_package(), config);
  REQUIRE(planner.wait_idle());
  planner.advance(0.5);  // playhead at frame 10; 30 frames queued ahead
  REQUIRE(planner.wait_idle());
  REQUIRE(published(planner).size() == 1);
  const auto before = queued_frames(planner, 0, 40);
  REQUIRE(before.size() == 40);

  planner.set_prompt("a person runs forward");
  REQUIRE(planner.wait_idle());
  const auto log = published(planner);
  REQUIRE(log.size() == 2);
  const WindowRecord& w = log.back();
  CHECK(w.spliced);
  CHECK(w.playhead_frame == 10);
  // B covers the latency (0.3 s = 6 frames) plus the interpolation frame, on the token grid.
  CHECK(w.start_frame == token_ceil(10 + 2 + 6));
  CHECK(w.buffer_frames == 10);
  CHECK(w.prompt == std::string("a person runs forward"));
  CHECK(w.history_tokens == 5);  // the first window's first 5 tokens are the history now
  CHECK(w.commands == 1);

  const auto after = queued_frames(planner, 0, 80);
  for (int64_t f = 0; f < w.start_frame; ++f) {
    INFO("frame " << f);
    REQUIRE(after.count(f));
    CHECK(after.at(f) == before.at(f));  // the replan buffer is untouched
  }
  for (int64_t f = w.start_frame; f < w.start_frame + 40; ++f) {
    REQUIRE(after.count(f));
    CHECK(after.at(f).window == w.id);
  }
  CHECK_FALSE(after.count(w.start_frame + 40));
  CHECK(planner.stats().splices == 1);
}

TEST_CASE("the replan buffer grows with the measured latency of recent windows", "[planner]") {
  ModelDouble model;
  model.fake_latency = 0.1;
  PlannerConfig config = model.fake_clock_config();
  config.latency_margin = 1.0;
  config.initial_latency_seconds = 0.1;
  config.min_buffer_frames = 3;
  Planner planner(tiny_package(), config);
  REQUIRE(planner.wait_idle());
  planner.set_prompt("a person walks");
  REQUIRE(planner.wait_idle());
  const WindowRecord fast = published(planner).back();
  // 0.1 s = 2 frames: max(0 + 2 + 2, 0 + 1 + 3) = 4.
  CHECK(fast.start_frame == 4);

  model.fake_latency = 0.8;  // the model slows down
  planner.set_prompt("a person walks slowly");
  REQUIRE(planner.wait_idle());
  CHECK(planner.stats().latency_estimate_seconds == Catch::Approx(0.8));
  planner.set_prompt("a person runs");
  REQUIRE(planner.wait_idle());
  const WindowRecord slow = published(planner).back();
  // 0.8 s = 16 frames: 0 + 2 + 16 = 18 -> 20.
  CHECK(slow.start_frame == 20);
  CHECK(slow.buffer_frames >= 16 + 1);
  // The low-water mark also covers the latency.
  CHECK(planner.queued_seconds() >= 0.8);
}

TEST_CASE("a window that comes back after the playhead reached its splice is thrown away and redone", "[planner]") {
  ModelDouble model;
  PlannerConfig config = model.fake_clock_config();
  config.initial_latency_seconds = 0.0;
  config.latency_margin = 1.0;
  Planner planner(tiny_package(), config);
  REQUIRE(planner.wait_idle());
  const auto before = queued_frames(planner, 0, 40);
  // The next window takes 1 s of planner time, during which the caller plays 0.6 s.
  std::atomic<int> slow_windows{1};
  model.on_window = [&] {
    if (slow_windows.fetch_sub(1) > 0) {
      model.clock = model.clock.load() + 1.0;
      planner.advance(0.6);
    }
  };
  planner.set_prompt("a person turns");  // spliced at frame 4, but the playhead reaches frame 12
  REQUIRE(planner.wait_idle());
  const auto log = planner.window_log();
  REQUIRE(log.size() == 3);
  CHECK(log[1].outcome == WindowOutcome::late);
  CHECK(log[1].start_frame == 4);
  CHECK(log[2].outcome == WindowOutcome::published);
  CHECK(log[2].start_frame == token_ceil(12 + 2 + 20));  // sized for the 1 s it measured
  CHECK(planner.stats().late_windows == 1);
  const auto after = queued_frames(planner, 0, 40);
  for (int64_t f = 0; f < log[2].start_frame; ++f) CHECK(after.at(f) == before.at(f));
  model.on_window = nullptr;
}

TEST_CASE("a slow model still yields a continuous frame stream across replans", "[planner][threads]") {
  // Each model with the output filter on and off. The shipped (trained) model
  // also runs the constraint path end to end (root interpolation, the speed
  // limit, root continuity): a waypoint it must sprint to when windows come
  // late, then keyboard steering.
  struct Case {
    const char* name;
    ModelDouble::Kind kind;
    bool shipped;
    std::optional<double> smoothing;  // unset: the package's
    int delay_ms;                     // per model call
  };
  const Case c = GENERATE(Case{"smooth double, unfiltered", ModelDouble::Kind::smooth, false, 0.0, 20},
                          Case{"smooth double, filtered", ModelDouble::Kind::smooth, false, 1.5, 20},
                          Case{"random weights, unfiltered", ModelDouble::Kind::real, false, 0.0, 2},
                          Case{"random weights, filtered", ModelDouble::Kind::real, false, 1.5, 2},
                          Case{"shipped model, its filter", ModelDouble::Kind::real, true, std::nullopt, 0},
                          Case{"shipped model, unfiltered", ModelDouble::Kind::real, true, 0.0, 0});
  ModelDouble model(c.kind);
  model.delay_ms = c.delay_ms;
  // The planner measures latency on the game's clock, which the caller's loop advances.
  std::atomic<double> game_time{0.0};
  PlannerConfig config = model.config();
  config.clock = [&] { return game_time.load(); };
  config.output_smoothing_frames = c.smoothing;
  Planner planner(c.shipped ? shipped_package() : tiny_package(), config);
  REQUIRE(planner.wait_idle());
  planner.set_prompt("a person walks");
  planner.set_prompt_at(4.5, "a person runs");

  PlaybackRecorder recorder;
  Pose pose;
  const double dt = 1.0 / 30.0;
  bool prompt_changed = false, waypoint = false, velocity = false;
  // Six seconds of motion (more steps when the model cannot keep up and the playhead waits).
  for (int step = 0; step < 20000 && planner.time() < 6.0; ++step) {
    planner.advance(dt);
    game_time = game_time.load() + dt;
    REQUIRE(planner.sample_current(pose));
    recorder.observe(planner);
    const double t = planner.time();
    if (!prompt_changed && t >= 1.0) {
      planner.set_prompt("a person turns around");
      prompt_changed = true;
    }
    if (!waypoint && t >= 2.0) {
      planner.add_waypoint(t + 2.0, 1.0, 3.0);
      waypoint = true;
    }
    if (!velocity && t >= 3.0) {
      planner.set_target_velocity(1.0, 0.5);
      velocity = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  REQUIRE(planner.wait_idle());
  CHECK(planner.take_errors().empty());
  // Nothing the caller has seen ever changes: no pops.
  CHECK(recorder.changed() == 0);
  const auto jumps = recorder.jumps();
  const auto stats = planner.stats();
  std::cout << "continuity (" << c.name << "): largest step across "
            << jumps.splices << " window joins " << jumps.across << " m, within windows " << jumps.within
            << " m, root " << jumps.root << " m; "
            << stats.windows_published << " windows, " << stats.splices << " splices, " << stats.late_windows
            << " late, " << stats.cancelled_windows << " cancelled, B " << stats.buffer_frames << " frames, latency "
            << stats.latency_estimate_seconds << " s, underrun " << stats.underrun_seconds << " s\n";
  INFO("across windows " << jumps.across << " m, within " << jumps.within << " m, " << jumps.splices << " joins");
  CHECK(jumps.splices >= 3);
  CHECK(jumps.within > 0.0);
  CHECK(jumps.across <= 1.5 * jumps.within);
  if (c.shipped) {
    // The root never teleports: root goals are limited to 6 m/s (0.3 m a
    // frame), and the model's free frames follow on from the overwritten ones.
    CHECK(jumps.root <= 0.45);
  }
  CHECK(stats.windows_published >= 4);
  CHECK(stats.commands == 5);
  // The prompt change reached the windows.
  const auto log = published(planner);
  CHECK(std::any_of(log.begin(), log.end(),
                    [](const WindowRecord& r) { return r.prompt == std::string("a person turns around"); }));
}

// --- coalescing, prompt timeline, cancellation ---------------------------------------------

TEST_CASE("commands that arrive while a window is in flight are coalesced into the next window", "[planner]") {
  ModelDouble model(ModelDouble::Kind::smooth);
  Planner planner(tiny_package(), model.fake_clock_config());
  REQUIRE(planner.wait_idle());
  model.close_gate();
  planner.set_prompt("a person walks");  // a splice; held in flight by the gate
  REQUIRE(model.wait_entered(2));
  planner.set_prompt("a person runs");
  planner.add_waypoint(3.0, 1.0, 2.0);
  planner.set_target_velocity(0.5, 1.0);
  planner.add_joint_target({2.5, "Hand_R", glm::dvec3(0.3, 1.4, 0.2), std::nullopt, std::nullopt});
  planner.set_prompt("a person turns");
  model.open_gate();
  REQUIRE(planner.wait_idle());
  const auto log = planner.window_log();
  REQUIRE(log.size() == 3);
  CHECK(model.windows == 3);
  CHECK(log[1].outcome == WindowOutcome::published);
  CHECK(log[1].prompt == std::string("a person walks"));
  CHECK(log[1].commands == 1);
  CHECK(log[2].outcome == WindowOutcome::published);
  CHECK(log[2].commands == 5);
  CHECK(log[2].prompt == std::string("a person turns"));
  const auto inputs = model.inputs();
  CHECK(inputs.back().goals.has_constraints());
}

TEST_CASE("prompt B at time t starts a window at the first token boundary at or after t", "[planner]") {
  ModelDouble model(ModelDouble::Kind::smooth);
  PlannerConfig config = model.fake_clock_config();
  config.keep_behind_seconds = 20.0;
  Planner planner(tiny_package(), config);
  planner.set_prompt("a person walks");
  REQUIRE(planner.wait_idle());

  SECTION("beyond the queued frames: the window reaching t is cut there") {
    planner.set_prompt_at(3.1, "a person runs");  // frame 62 -> boundary 64
    REQUIRE(planner.wait_idle());
    while (planner.time() < 5.0) {
      planner.advance(0.1);
      REQUIRE(planner.wait_idle());
    }
  }
  SECTION("inside the queued frames: a splice at t") {
    planner.advance(2.0);
    REQUIRE(planner.wait_idle());
    REQUIRE(planner.queued_seconds() > 1.2);
    planner.set_prompt_at(3.1, "a person runs");
    REQUIRE(planner.wait_idle());
    CHECK(published(planner).back().spliced);
    while (planner.time() < 5.0) {
      planner.advance(0.1);
      REQUIRE(planner.wait_idle());
    }
  }
  const auto log = published(planner);
  const auto b = std::find_if(log.begin(), log.end(), [](const WindowRecord& r) { return r.start_frame == 64; });
  REQUIRE(b != log.end());
  CHECK(b->prompt == std::string("a person runs"));
  Pose pose;
  std::map<uint64_t, WindowRecord> by_id;
  for (const WindowRecord& r : log) by_id[r.id] = r;
  for (int64_t f = 0; f < 100; ++f) {
    REQUIRE(planner.frame_at(f, pose));
    INFO("frame " << f);
    const WindowRecord& r = by_id.at(pose.window_id);
    if (f < 64) {
      CHECK(r.prompt != std::string("a person runs"));
    } else {
      CHECK(r.prompt == std::string("a person runs"));
    }
  }
}

TEST_CASE("an appended window that a new command makes obsolete is cancelled", "[planner]") {
  ModelDouble model(ModelDouble::Kind::smooth);
  Planner planner(tiny_package(), model.fake_clock_config());
  REQUIRE(planner.wait_idle());
  model.close_gate();
  planner.advance(1.2);  // 16 frames ahead < 20: the next window is appended at frame 40
  REQUIRE(model.wait_entered(2));
  planner.set_prompt("a person runs");  // wants a splice at frame 28 < 40
  REQUIRE(eventually([&] { return planner.stats().cancelled_windows == 1; }));
  model.open_gate();
  REQUIRE(planner.wait_idle());
  const auto log = planner.window_log();
  REQUIRE(log.size() == 3);
  CHECK(log[1].outcome == WindowOutcome::cancelled);
  CHECK(log[1].start_frame == 40);
  CHECK(log[2].outcome == WindowOutcome::published);
  CHECK(log[2].start_frame == 28);
  CHECK(log[2].prompt == std::string("a person runs"));
  CHECK(planner.take_errors().empty());
}

TEST_CASE("destroying a planner while a window is in flight returns promptly and frees everything",
          "[planner][threads]") {
  SECTION("the real model between denoiser calls") {
    ModelDouble model(ModelDouble::Kind::real);
    model.delay_ms = 5;
    auto planner = std::make_unique<Planner>(tiny_package(), model.config());
    REQUIRE(eventually([&] { return model.model_calls.load() >= 2; }));
    planner->set_prompt("a person walks");
    planner->add_waypoint(1.0, 1.0, 1.0);
    const int calls_before = model.model_calls.load();
    planner.reset();
    // The window stopped at the next call: at most the one sleeping then, and the refusing one.
    CHECK(model.saw_cancel);
    CHECK(model.model_calls.load() - calls_before <= 2);
  }
  SECTION("a window held in flight") {
    ModelDouble model(ModelDouble::Kind::smooth);
    model.close_gate();
    auto planner = std::make_unique<Planner>(tiny_package(), model.config());
    REQUIRE(model.wait_entered(1));
    planner.reset();
    CHECK(model.saw_cancel);
  }
  // Mostly for the sanitizer builds (a leak or a race on teardown shows there); what can be
  // asserted in every build is asserted.
  SECTION("right after construction, many times (sanitizers: no leak, no race on teardown)") {
    ModelDouble model(ModelDouble::Kind::real);
    for (int i = 0; i < 10; ++i) {
      auto planner = std::make_unique<Planner>(tiny_package(), model.config());
      if (i % 2) planner->set_prompt("a person walks");
      if (i % 3 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(i));
      CHECK(planner->take_errors().empty());
      planner.reset();
      // The destructor returned only after the worker left the generator.
      CHECK(model.in_flight.load() == 0);
    }
    // The shared package and the generator still serve a new planner.
    Planner planner(tiny_package(), model.config());
    REQUIRE(planner.wait_idle());
    Pose pose;
    REQUIRE(planner.sample_current(pose));
    CHECK(pose.local_rotations.size() == 21);
    CHECK(planner.take_errors().empty());
  }
}

TEST_CASE("several callers and planners share a package and the API from several threads", "[planner][threads]") {
  ModelDouble model_a(ModelDouble::Kind::real), model_b(ModelDouble::Kind::smooth);
  Planner a(tiny_package(), model_a.config());
  Planner b(tiny_package(), model_b.config());
  std::atomic<bool> done{false};
  std::thread reader([&] {
    Pose pose;
    while (!done) {
      a.sample(a.time() + 0.05, pose);
      b.sample_current(pose);
      (void)a.stats();
      std::this_thread::yield();
    }
  });
  std::thread commander([&] {
    for (int i = 0; i < 20; ++i) {
      b.set_prompt(i % 2 ? "a person walks" : "a person runs");
      a.add_waypoint(2.0 + 0.1 * i, 0.1 * i, 1.0);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  Pose pose;
  for (int i = 0; i < 60; ++i) {
    a.advance(0.05);
    b.advance(0.05);
    a.sample_current(pose);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  commander.join();
  done = true;
  reader.join();
  REQUIRE(a.wait_idle());
  REQUIRE(b.wait_idle());
  CHECK(a.take_errors().empty());
  CHECK(b.take_errors().empty());
  CHECK(a.stats().commands == 20);
  CHECK(b.stats().commands == 20);
}

// --- constraints reach the windows -------------------------------------------------------------

TEST_CASE("constraints and keyboard velocity become the windows' goals", "[planner]") {
  ModelDouble model(ModelDouble::Kind::smooth);
  Planner planner(tiny_package(), model.fake_clock_config());
  REQUIRE(planner.wait_idle());
  CHECK_FALSE(model.inputs().back().goals.has_constraints());

  planner.set_target_velocity(1.0, 0.0);
  REQUIRE(planner.wait_idle());
  WindowInput in = model.inputs().back();
  REQUIRE(in.goals.any_window_constraint);
  // Root x goals of the window's frames are set (the integrated velocity path).
  const ardy::ModelPackage& p = *tiny_package();
  const size_t m = p.layout().feature_size;
  CHECK(in.goals.window_goal_mask[0 * m + p.layout().root_position.start] == 1.0f);
  CHECK(published(planner).back().spliced);

  planner.clear_target_velocity();
  REQUIRE(planner.wait_idle());
  CHECK_FALSE(model.inputs().back().goals.has_constraints());

  const auto id = planner.add_waypoint(1.5, 2.0, 1.0, 0.5);
  planner.add_path(0.5, {{0.0, 0.0}, {1.0, 1.0}}, 1.0, true);
  planner.add_keyframe_pose(1.0, [&] {
    Pose pose;
    REQUIRE(planner.frame_at(10, pose));
    return pose;
  }());
  planner.add_joint_target({1.2, "Hand_L", std::nullopt, glm::dquat(1.0, 0.0, 0.0, 0.0), std::nullopt});
  planner.add_joint_target({1.2, "Hand_R", glm::dvec3(1.0, 1.2, 2.0), std::nullopt, glm::dvec2(0.8, 2.0)});
  planner.add_contact(0.5, 1.5, {"Foot_L", "Toes_L"});
  REQUIRE(planner.wait_idle());
  in = model.inputs().back();
  CHECK(in.goals.any_window_constraint);
  CHECK(planner.stats().commands == 2 + 6);

  planner.remove_constraint(id);
  planner.clear_constraints();
  REQUIRE(planner.wait_idle());
  CHECK_FALSE(model.inputs().back().goals.has_constraints());

  // A waypoint far beyond every window's future horizon waits without a replan.
  const size_t windows = model.inputs().size();
  planner.add_waypoint(100.0, 5.0, 5.0);
  REQUIRE(planner.wait_idle());
  CHECK(model.inputs().size() == windows);
  CHECK(planner.take_errors().empty());

  // Root targets a window can see take precedence over the keyboard velocity
  // (two root goals that disagree would pull the root apart).
  const auto root_x_goals = [&](const WindowInput& w) {
    size_t n = 0;
    for (const auto* mask : {&w.goals.window_goal_mask, &w.goals.future_goal_mask}) {
      for (size_t i = p.layout().root_position.start; i < mask->size(); i += m) n += (*mask)[i] != 0.0f;
    }
    return n;
  };
  planner.set_target_velocity(1.0, 0.0);
  REQUIRE(planner.wait_idle());
  CHECK(root_x_goals(model.inputs().back()) > 10);  // the velocity path
  const auto near = planner.add_waypoint(planner.time() + 2.0, 2.0, 1.0);
  REQUIRE(planner.wait_idle());
  CHECK(root_x_goals(model.inputs().back()) == 1);  // the waypoint alone
  planner.remove_constraint(near);
  REQUIRE(planner.wait_idle());
  CHECK(root_x_goals(model.inputs().back()) > 10);
  CHECK(planner.take_errors().empty());
}

TEST_CASE("foot locking holds the planted feet of the frames the planner shows", "[planner]") {
  // The same window (fake clock, same seed) with foot locking on and off, over a few seeds:
  // one draw can drag a flagged foot past the lock's let-go distance (the lock then lets it
  // go, by design, and its return counts as slide), so the figure is the seeds' total.
  const auto first_window = [](bool foot_lock, uint64_t seed) {
    PlannerConfig config;
    config.clock = [] { return 0.0; };
    config.foot_lock = foot_lock;
    config.seed = seed;
    Planner planner(shipped_package(), config);
    REQUIRE(planner.wait_idle());  // the first window, then the prompt's splice: the same frames every run
    planner.set_prompt("a person walks forward");
    REQUIRE(planner.wait_idle());
    std::vector<Pose> frames(40);
    for (int64_t f = 0; f < 40; ++f) REQUIRE(planner.frame_at(f, frames[size_t(f)]));
    return frames;
  };
  const ardy::ModelPackage& p = *shipped_package();
  double slide_locked = 0.0, slide_free = 0.0;
  size_t planted = 0;
  const size_t right_hand = p.skeleton().index_of("Hand_R");
  for (uint64_t seed = 0; seed < 4; ++seed) {
    const std::vector<Pose> locked = first_window(true, seed), free = first_window(false, seed);
    double seed_locked = 0.0, seed_free = 0.0;
    for (const char* foot : {"Foot_L", "Foot_R"}) {
      const size_t ankle = p.skeleton().index_of(foot);
      const size_t flag = foot == std::string("Foot_L") ? 0 : 2;
      for (size_t f = 5; f < locked.size(); ++f) {
        bool held = true;  // planted for the last 5 frames: the hold has eased in
        for (size_t back = 0; back <= 5; ++back) held = held && locked[f - back].contacts[flag] > 0.6f;
        if (!held) continue;
        const auto slide = [&](const std::vector<Pose>& w) {
          const glm::vec3 d = w[f].positions[ankle] - w[f - 1].positions[ankle];
          return double(std::hypot(d.x, d.z));
        };
        seed_locked += slide(locked);
        seed_free += slide(free);
        ++planted;
      }
    }
    // Hips and arms are untouched.
    for (size_t f = 0; f < locked.size(); ++f) {
      CHECK(locked[f].positions[0] == free[f].positions[0]);
      CHECK(locked[f].positions[right_hand] == free[f].positions[right_hand]);
    }
    std::cout << "foot lock, seed " << seed << ": ankle slide " << seed_locked << " m locked vs " << seed_free
              << " m free\n";
    slide_locked += seed_locked;
    slide_free += seed_free;
  }
  std::cout << "foot lock: " << planted << " planted frames, ankle slide " << slide_locked << " m locked vs "
            << slide_free << " m free\n";
  REQUIRE(planted >= 20);
  CHECK(slide_locked < 0.3 * slide_free);
}

TEST_CASE("a planner continues the motion it is given as initial history", "[planner]") {
  const ardy::ModelPackage& p = *tiny_package();
  const ardy::FeatureLayout& layout = p.layout();
  const size_t m = layout.feature_size, frames = 8;
  // Walking along +x at 1 m/s, ending at (3.35, -2) just before time 0.
  const double speed = 1.0, psi = std::atan2(1.0, 0.0);
  std::vector<float> history(frames * m, 0.0f);
  for (size_t f = 0; f < frames; ++f) {
    float* row = history.data() + f * m;
    row[layout.root_position.start + 0] = float(3.0 + speed * double(f) / p.fps());
    row[layout.root_position.start + 1] = 0.9f;
    row[layout.root_position.start + 2] = -2.0f;
    row[layout.heading.start + 0] = float(std::cos(psi));
    row[layout.heading.start + 1] = float(std::sin(psi));
    for (size_t j = 0; j < layout.joint_count; ++j) {
      ardy::rotation_to_6d(ardy::heading_rotation(float(psi)), row + layout.rotation_6d_of(j).start);
    }
  }
  const glm::vec3 last(history[(frames - 1) * m], 0.9f, -2.0f);
  const glm::vec3 step(float(speed / p.fps()), 0.0f, 0.0f);

  for (const double smoothing : {0.0, 1.5}) {
    INFO("output filter sigma " << smoothing);
    ModelDouble model(ModelDouble::Kind::smooth);
    PlannerConfig config = model.fake_clock_config();
    config.initial_history = history;
    config.output_smoothing_frames = smoothing;
    Planner planner(tiny_package(), config);
    REQUIRE(planner.wait_idle());
    const WindowInput first = model.inputs().front();
    CHECK(first.history_tokens == frames / p.tokens().patch);
    CHECK(first.offset.x == Catch::Approx(last.x));
    CHECK(first.offset.y == Catch::Approx(last.z));
    // Frame 0 follows on from the last history frame at its speed.
    Pose pose;
    REQUIRE(planner.frame_at(0, pose));
    CHECK(glm::length(pose.root_position - (last + step)) < 0.01f);
    REQUIRE(planner.frame_at(1, pose));
    CHECK(glm::length(pose.root_position - (last + 2.0f * step)) < 0.02f);
  }

  PlannerConfig bad;
  bad.initial_history.assign(6 * m, 0.0f);
  CHECK_THAT(error_message([&] { Planner planner(tiny_package(), bad); }),
             ContainsSubstring("initial_history: Rollout::seed_history: 6 frames, expected a positive multiple"));
  bad.initial_history = history;
  bad.initial_history[3 * m + 7] = std::nanf("");
  CHECK_THAT(error_message([&] { Planner planner(tiny_package(), bad); }),
             ContainsSubstring("feature 7 of frame 3 is not finite"));
  bad.initial_history.resize(frames * m - 1);
  CHECK_THAT(error_message([&] { Planner planner(tiny_package(), bad); }),
             ContainsSubstring("not a whole number of frames"));
}

TEST_CASE("the config's prompt is the first window's, so equal configs give equal motion", "[planner]") {
  std::vector<std::vector<glm::vec3>> runs;
  for (int run = 0; run < 2; ++run) {
    PlannerConfig config;
    config.prompt = "a person walks forward";
    config.seed = 9;
    Planner planner(tiny_package(), config);
    REQUIRE(planner.wait_idle());
    const std::vector<WindowRecord> log = planner.window_log();
    REQUIRE(!log.empty());
    CHECK(log.front().prompt == std::optional<std::string>("a person walks forward"));
    CHECK(log.front().start_frame == 0);
    Pose pose;
    std::vector<glm::vec3> roots;
    for (int64_t frame = 0; frame < 20; ++frame) {
      REQUIRE(planner.frame_at(frame, pose));
      roots.push_back(pose.root_position);
    }
    runs.push_back(roots);
  }
  for (size_t frame = 0; frame < runs[0].size(); ++frame) {
    CHECK(glm::length(runs[0][frame] - runs[1][frame]) < 1e-5f);
  }
  PlannerConfig bad;
  bad.prompt = std::string(5000, 'x');
  CHECK_THAT(error_message([&] { Planner planner(tiny_package(), bad); }), ContainsSubstring("Planner config: prompt"));
}

// --- errors --------------------------------------------------------------------------------------

TEST_CASE("malformed inputs give clear errors and leave the planner usable", "[planner][errors]") {
  ModelDouble model(ModelDouble::Kind::smooth);
  Planner planner(tiny_package(), model.fake_clock_config());
  REQUIRE(planner.wait_idle());

  CHECK_THAT(error_message([&] { planner.set_prompt(""); }), ContainsSubstring("set_prompt: prompt is empty"));
  CHECK_THAT(error_message([&] { planner.set_prompt(std::string(10000, 'a')); }),
             ContainsSubstring("10000 characters"));
  CHECK_THAT(error_message([&] { planner.set_prompt("walk \xff"); }), ContainsSubstring("UTF-8"));
  CHECK_THAT(error_message([&] { planner.set_prompt_at(std::nan(""), "a person walks"); }),
             ContainsSubstring("set_prompt_at"));
  CHECK_THAT(error_message([&] { planner.add_waypoint(1.0, std::nan(""), 0.0); }),
             ContainsSubstring("add_waypoint"));
  CHECK_THAT(error_message([&] { planner.add_waypoint(1.0, 0.0, 0.0, INFINITY); }), ContainsSubstring("heading"));
  CHECK_THAT(error_message([&] { planner.add_waypoint(INFINITY, 0.0, 0.0); }), ContainsSubstring("finite"));
  CHECK_THAT(error_message([&] {
               planner.add_joint_target({1.0, "Hand", glm::dvec3(0.0), std::nullopt, std::nullopt});
             }),
             ContainsSubstring("unknown joint 'Hand'"));
  CHECK_THAT(error_message([&] {
               planner.add_joint_target({1.0, "Hand_R", std::nullopt, glm::dquat(0.0, 0.0, 0.0, 0.0), std::nullopt});
             }),
             ContainsSubstring("quaternion"));
  CHECK_THAT(error_message([&] {
               planner.add_joint_target({1.0, "Hand_R", glm::dvec3(0.0, NAN, 0.0), std::nullopt, std::nullopt});
             }),
             ContainsSubstring("position.y is NaN"));
  CHECK_THAT(error_message([&] { planner.add_joint_target({1.0, "Hand_R", std::nullopt, std::nullopt, std::nullopt}); }),
             ContainsSubstring("neither a position nor a rotation"));
  CHECK_THAT(error_message([&] { planner.add_contact(1.0, 2.0, {"Foot_X"}); }), ContainsSubstring("unknown foot 'Foot_X'"));
  CHECK_THAT(error_message([&] { planner.add_contact(2.0, 1.0, {}); }), ContainsSubstring("end_frame"));
  CHECK_THAT(error_message([&] { planner.add_keyframe(1.0, {1.0, 2.0, 3.0}); }),
             ContainsSubstring("features has 3 values, expected 258"));
  CHECK_THAT(error_message([&] { planner.add_path(0.0, {{0.0, 0.0}}, 1.0); }), ContainsSubstring("add_path"));
  CHECK_THAT(error_message([&] { planner.add_path(0.0, {{0.0, 0.0}, {1.0, 0.0}}, -1.0); }), ContainsSubstring("speed"));
  CHECK_THAT(error_message([&] { planner.add_path_frames(0.0, {}); }), ContainsSubstring("positions is empty"));
  CHECK_THAT(error_message([&] { planner.set_target_velocity(NAN, 0.0); }), ContainsSubstring("vx is NaN"));
  CHECK_THAT(error_message([&] { planner.advance(-0.1); }), ContainsSubstring("advance: delta"));
  CHECK_THAT(error_message([&] { planner.advance(NAN); }), ContainsSubstring("NaN"));
  CHECK_THAT(error_message([&] { planner.set_sampling(0, std::nullopt, std::nullopt); }), ContainsSubstring("steps is 0"));
  CHECK_THAT(error_message([&] { planner.set_sampling(std::nullopt, NAN, std::nullopt); }), ContainsSubstring("w_text"));
  CHECK_THAT(error_message([&] { planner.set_sampling(std::nullopt, std::nullopt, std::nullopt, 0.0f); }),
             ContainsSubstring("path_guidance_scale is 0, expected (0, 1]"));
  CHECK_THAT(error_message([&] { planner.set_sampling(std::nullopt, std::nullopt, std::nullopt, 1.5f); }),
             ContainsSubstring("path_guidance_scale is 1.5"));
  CHECK_THAT(error_message([&] { planner.set_sampling(std::nullopt, std::nullopt, std::nullopt, std::nullopt, 0.0f); }),
             ContainsSubstring("text_only_guidance_scale is 0, expected (0, 4]"));
  CHECK_THAT(error_message([&] { planner.set_sampling(std::nullopt, std::nullopt, std::nullopt, std::nullopt, 4.5f); }),
             ContainsSubstring("text_only_guidance_scale is 4.5"));

  // Nothing reached the worker; the planner still works.
  REQUIRE(planner.wait_idle());
  CHECK(planner.stats().commands == 0);
  planner.set_prompt("a person walks");
  CHECK(model.inputs().back().path_guidance_scale == 1.0f);  // the tiny package's
  CHECK(model.inputs().back().text_only_guidance_scale == 1.0f);
  planner.set_sampling(2, 1.5f, 1.0f, 0.25f, 1.5f);
  planner.set_prompt("a person runs");
  REQUIRE(planner.wait_idle());
  CHECK(published(planner).back().prompt == std::string("a person runs"));
  CHECK(model.inputs().back().steps == 2);
  CHECK(model.inputs().back().w_con == 1.0f);
  CHECK(model.inputs().back().path_guidance_scale == 0.25f);
  CHECK(model.inputs().back().text_only_guidance_scale == 1.5f);
  CHECK(planner.take_errors().empty());

  PlannerConfig bad = model.config();
  bad.history_seconds = -1.0;
  CHECK_THAT(error_message([&] { Planner p(tiny_package(), bad); }), ContainsSubstring("history_seconds"));
  bad = model.config();
  bad.latency_margin = 0.5;
  CHECK_THAT(error_message([&] { Planner p(tiny_package(), bad); }), ContainsSubstring("latency_margin"));
  bad = model.config();
  bad.steps = 99;
  CHECK_THAT(error_message([&] { Planner p(tiny_package(), bad); }), ContainsSubstring("steps is 99"));
  CHECK_THAT(error_message([&] { Planner p(nullptr); }), ContainsSubstring("no model package"));
}

TEST_CASE("a window failing on the worker is reported and the planner keeps running", "[planner][errors]") {
  ModelDouble model(ModelDouble::Kind::smooth);
  model.fail_on_prompt = "a person explodes";
  Planner planner(tiny_package(), model.fake_clock_config());
  planner.set_prompt("a person walks");
  REQUIRE(planner.wait_idle());
  planner.set_prompt("a person explodes");
  REQUIRE(planner.wait_idle());
  CHECK_THAT(planner.last_error(), ContainsSubstring("refuses the prompt 'a person explodes'"));
  const auto errors = planner.take_errors();
  REQUIRE(errors.size() == 1);
  CHECK_THAT(errors[0], ContainsSubstring("the window at frame 4 failed"));
  CHECK_THAT(errors[0], ContainsSubstring("dropped"));
  CHECK(planner.take_errors().empty());
  CHECK(planner.stats().failed_windows == 1);

  // Playing on continues with the last good prompt.
  for (int i = 0; i < 30; ++i) {
    planner.advance(0.1);
    REQUIRE(planner.wait_idle());
  }
  const auto log = published(planner);
  CHECK(log.back().prompt == std::string("a person walks"));
  CHECK(log.back().start_frame > 40);
  planner.set_prompt("a person runs");
  REQUIRE(planner.wait_idle());
  CHECK(published(planner).back().prompt == std::string("a person runs"));
  std::string message;
  CHECK_FALSE(planner.pop_error(message));
}

TEST_CASE("the playhead holds the last frame while the model cannot keep up", "[planner]") {
  ModelDouble model(ModelDouble::Kind::smooth);
  Planner planner(tiny_package(), model.fake_clock_config());
  REQUIRE(planner.wait_idle());
  model.close_gate();
  planner.advance(10.0);
  CHECK(planner.time() == Catch::Approx(39.0 / kFps));
  CHECK(planner.stats().underrun_seconds == Catch::Approx(10.0 - 39.0 / kFps));
  Pose pose, last;
  REQUIRE(planner.sample_current(pose));
  REQUIRE(planner.frame_at(39, last));
  CHECK(pose.positions == last.positions);
  model.open_gate();
  REQUIRE(planner.wait_idle());
  planner.advance(0.5);
  CHECK(planner.time() == Catch::Approx(49.0 / kFps));
}

TEST_CASE("reset_prompts_at forgets the prompts queued after it", "[planner]") {
  PlannerConfig config;
  config.prompt = "a person walks";
  config.initial_prompts = {{40, std::string("a person waves")}};
  Planner planner(tiny_package(), config);
  planner.reset_prompts_at(0.0, std::string("a person runs"));
  for (int step = 0; step < 40; ++step) {
    REQUIRE(planner.wait_idle());
    planner.advance(0.1);
  }
  REQUIRE(planner.wait_idle());
  int runs = 0, waves = 0;
  for (const WindowRecord& record : planner.window_log()) {
    if (record.outcome != WindowOutcome::published) continue;
    runs += record.prompt == std::string("a person runs");
    waves += record.prompt == std::string("a person waves");
  }
  CHECK(planner.time() > 3.5);
  CHECK(runs >= 2);
  CHECK(waves == 0);
}
