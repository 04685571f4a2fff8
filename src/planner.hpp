#pragma once

// The streaming planner (design.md section 8, paper section 4.1 and Fig. 5):
// one worker thread per planner generates windows ahead of a playhead that
// the caller moves with advance(delta), and the caller samples poses at any
// time from the queue of generated frames.
//
// Threads. The caller's thread (the game's main thread) only pushes commands
// into a briefly-locked inbox, and moves the playhead and samples the frame
// queue under a lock that the worker holds only to check the playhead and
// swap in a new list of frame blocks (a few pointer copies). sample(), sample_current(), frame_at() and advance() never
// allocate once the Pose has the skeleton's size, never wait on inference and
// never call ONNX Runtime. Every public method is thread-safe.
//
// Time. The planner's clock is seconds of played motion: model frame f sits
// at time f / fps, the first window starts at frame 0 = time 0. advance()
// moves the playhead but never past the last generated frame: when the model
// cannot keep up (an underrun) the motion holds its last frame instead of
// jumping later (stats().underrun_seconds counts it).
//
// Replanning. A window is generated when
//   - a command asks for one: a prompt now, a changed constraint that a
//     queued window could see (in-window or within the future horizon), a
//     changed target velocity; or a future prompt whose start is already
//     covered by the queue (prompt timeline, below);
//   - the queue ahead of the playhead runs below low_water_seconds (raised
//     to cover the measured latency): the window is appended at the end.
// Latency-aware splice: the B frames after the playhead keep playing and
// become the end of the history; the new window starts right after them, at
// a token boundary (P frames per token), so nothing the caller has seen
// changes: frames before the splice stay bit-identical, the new window's
// frames replace everything after it. B covers the measured latency of the
// recent windows (max of the last latency_samples, times latency_margin),
// plus one frame for interpolation, at least min_buffer_frames, rounded up
// to the token grid. The committed history is rolled back to the splice by
// restoring a snapshot of the Rollout taken before the window that holds the
// splice and re-committing its first tokens. If a window comes back after the
// playhead has reached its splice (the model was slower than measured), it is
// thrown away and made again with the larger latency (stats().late_windows).
// Commands that arrive while a window is in flight are coalesced into the
// next one (one window for any number of them).
//
// Prompt timeline. set_prompt() takes effect at the first window after the
// replan buffer; set_prompt_at(t) makes a window start exactly at the first
// token boundary at or after t (windows are cut there), so frames from that
// boundary on are generated with the new prompt.
//
// Errors. Inputs are validated on the caller's thread (Error with a message
// naming the call and the field; the planner is unchanged). A window that
// fails on the worker (a text encoder or graph failure, say) is reported in
// the error queue (take_errors(), last_error()); the commands applied since
// the last good window are rolled back and the planner keeps running.
//
// Shutdown. The destructor cancels an in-flight window (the CancelCheck is
// asked before every denoiser and decoder call), joins the worker and frees
// everything; it returns within one model call.

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "constraints.hpp"
#include "error.hpp"
#include "foot_lock.hpp"
#include "package.hpp"
#include "rollout.hpp"
#include "sampler.hpp"

namespace ardy {

// One pose of the character (interpolated between model frames, or one model
// frame). Vectors are resized to the skeleton on first use and then reused.
struct Pose {
  double time = 0.0;  // seconds of planner time the pose is for
  glm::vec3 root_position{0.0f};
  float heading = 0.0f;                    // psi, radians about +Y (0 faces +Z)
  std::vector<glm::quat> local_rotations;  // [J] parent-relative (root: world)
  std::vector<glm::vec3> positions;        // [J] world joint positions
  std::vector<float> contacts;             // [c] foot contact flags, linearly interpolated
  uint64_t window_id = 0;                  // the window of the earlier of the two frames
};

// Seconds, monotonic; measures window latency. Default: std::chrono::steady_clock.
using PlannerClock = std::function<double()>;

struct PlannerConfig {
  // Sampling; unset = the package's defaults.
  std::optional<size_t> steps;
  std::optional<float> w_text;
  std::optional<float> w_con;
  double history_seconds = 8.0;               // history window (clamped to tokens.max_history)
  std::optional<double> future_seconds;       // out-of-window goals (default and limit: tokens.max_future)
  size_t decode_context_tokens = 0;           // 0: the package default
  // Output filter sigma in frames (motion_filter.hpp) on the frames shown;
  // the history the model reads stays raw. Unset: the package's; 0: off.
  std::optional<double> output_smoothing_frames;
  // Foot locking (foot_lock.hpp) on the frames shown: planted feet stay put.
  bool foot_lock = true;
  // Joint targets reached on the frames shown (joint_reach.hpp): at the
  // target's frame the joint is at its position target (two-bone IK) and
  // turned to its rotation target.
  bool joint_reach = true;
  std::optional<bool> interpolate_root;           // GoalSpec::interpolate_root; default: the package's
  std::optional<float> path_guidance_scale;       // WindowInput::path_guidance_scale; default: the package's
  std::optional<float> text_only_guidance_scale;  // WindowInput::text_only_guidance_scale; default: the package's
  double max_root_speed = kDefaultMaxRootSpeed;   // GoalSpec::max_root_speed (m/s; 0: no limit)
  glm::dvec2 start_xz{0.0, 0.0};              // where the character starts (without initial_history)
  // What the character was doing before the planner starts (an animation it
  // played, a pose it holds for a few frames): world explicit features
  // [frames, M] (features.hpp layout), frames a positive multiple of the
  // patch size, the last one just before time 0. It becomes the history of
  // the first window, which continues it (and the output filter's left
  // context). Empty: the first window starts from nothing at start_xz.
  std::vector<float> initial_history;
  uint64_t seed = 0;                          // noise of the windows
  // The prompt of the first window (set_prompt() right after construction
  // races the first window; this does not): same seed, prompt and commands
  // give the same motion.
  std::optional<std::string> prompt;
  // A whole timeline known before the start (a cut-scene, a bake): prompt
  // events (frame, text; later ones override) and constraints in model
  // frames, validated here and applied before the first window, so no window
  // is made without them (the same config gives the same motion).
  // The initial constraints get the ids 1..n in order (remove_constraint).
  std::vector<PromptEvent> initial_prompts;
  std::vector<Constraint> initial_constraints;
  // Replan buffer and queue.
  size_t min_buffer_frames = 0;               // B is at least this many frames
  double initial_latency_seconds = 0.1;       // latency assumed before a window has been measured
  double latency_margin = 1.25;               // factor on the measured latency
  size_t latency_samples = 8;                 // recent windows the latency is taken from (max)
  double low_water_seconds = 1.0;             // append a window when less than this is queued ahead
  double keep_behind_seconds = 1.0;           // frames kept behind the playhead for sample(t < now)
  // Keyboard steering: the velocity blends from the current to the target
  // one over velocity_blend_seconds (default: one window), integrated over
  // velocity_path_seconds (default: one window) from the window start. Root
  // targets (waypoints, paths, keyframe roots) that a window can see (within
  // its future horizon) take precedence: the window ignores the velocity.
  std::optional<double> velocity_blend_seconds;
  std::optional<double> velocity_path_seconds;
  // Cancel an in-flight appended window as soon as a command asks for a
  // splice before its start (it would be replaced entirely).
  bool cancel_obsolete_windows = true;
  size_t max_errors = 32;  // queued error messages kept (oldest dropped)
  // How windows are made, and the latency clock. Empty: generate_window on
  // this planner's worker, and steady_clock. Several characters: give every
  // planner the generator() of one WindowBatcher (window_batcher.hpp). Tests
  // and tools wrap generate_window here (delay, faults, a fake clock).
  WindowGenerator generator;
  PlannerClock clock;
};

// A joint target: position and/or world rotation of a joint at a time.
struct JointTargetSpec {
  double time = 0.0;
  std::string joint;  // skeleton name, e.g. "Hand_R"
  // Non-root joints: relative to the root's ground projection (world
  // position minus (root.x, 0, root.z) at that time; the model's J feature),
  // or world space when root_xz is given (then converted with it). The root
  // joint: its world position.
  std::optional<glm::dvec3> position;
  std::optional<glm::dquat> rotation;  // world rotation
  std::optional<glm::dvec2> root_xz;
};

// The constraints Planner::add_keyframe_pose and add_joint_target add, for
// callers that build a whole timeline first (PlannerConfig::initial_constraints).
// Errors start with `what`.
PoseKeyframe keyframe_from_pose(const ModelPackage& package, int64_t frame, const Pose& pose, bool include_root,
                                const char* what);
JointTarget joint_target_from_spec(const ModelPackage& package, int64_t frame, const JointTargetSpec& spec,
                                   const char* what);

enum class WindowOutcome { published, late, cancelled, failed };
const char* window_outcome_name(WindowOutcome outcome);

// One generated window, for tests, tools and debugging overlays.
struct WindowRecord {
  uint64_t id = 0;
  int64_t start_frame = 0;
  size_t frames = 0;              // frames published (the window may be cut at a prompt boundary)
  bool spliced = false;           // replaced queued frames (false: appended at the end of the queue)
  int64_t playhead_frame = 0;     // floor of the playhead when the window started
  int64_t buffer_frames = 0;      // start_frame - playhead frame: B
  size_t history_tokens = 0;
  std::optional<std::string> prompt;
  double latency_seconds = 0.0;   // measured with the planner's clock
  size_t commands = 0;            // commands coalesced into it
  WindowOutcome outcome = WindowOutcome::published;
};

struct PlannerStats {
  uint64_t windows_started = 0;
  uint64_t windows_published = 0;
  uint64_t splices = 0;           // published windows that replaced queued frames
  uint64_t late_windows = 0;      // thrown away: the playhead reached their splice
  uint64_t cancelled_windows = 0;
  uint64_t failed_windows = 0;
  uint64_t commands = 0;          // commands applied by the worker
  uint64_t errors = 0;            // errors reported since creation
  double last_latency_seconds = 0.0;
  double latency_estimate_seconds = 0.0;  // what B and the low-water mark are sized for
  int64_t buffer_frames = 0;      // B of the last window
  double underrun_seconds = 0.0;  // playhead time lost waiting for frames
  double playhead = 0.0;          // seconds
  double queued_seconds = 0.0;    // generated motion ahead of the playhead
  bool window_in_flight = false;
};

class Planner {
 public:
  using ConstraintId = uint64_t;

  // Starts the worker, which generates the first window at once. Error for a
  // null package or an invalid config (named field).
  Planner(std::shared_ptr<const ModelPackage> package, PlannerConfig config = {});
  ~Planner();
  Planner(const Planner&) = delete;
  Planner& operator=(const Planner&) = delete;

  const ModelPackage& package() const { return *package_; }
  const PlannerConfig& config() const { return config_; }
  size_t joint_count() const;
  double fps() const { return fps_; }

  // --- caller's clock and frames (no allocation, no waiting) ---
  // Moves the playhead by delta seconds (finite, >= 0; Error otherwise), at
  // most to the last generated frame.
  void advance(double delta);
  double time() const;               // the playhead, seconds
  double queued_seconds() const;     // generated motion ahead of the playhead
  // The pose at time t (clamped to the frames kept: a little behind the
  // playhead up to the last generated frame). False when no frame exists yet
  // (out unchanged).
  bool sample(double t, Pose& out) const;
  bool sample_current(Pose& out) const { return sample(time(), out); }
  // Model frame `frame` exactly (no interpolation); false when it is not in
  // the queue.
  bool frame_at(int64_t frame, Pose& out) const;
  // The model's own frame `frame` as its window generated it, before the
  // output filter, foot locking and joint reach: what frame_at shows with
  // those steps undone (splices included: the window that shows the frame).
  // For tests and debugging overlays that compare the shown motion with the
  // model's (tests/cpp/test_continuity.cpp bounds the shown joint speeds by
  // the raw ones). False when the frame is not in the queue.
  bool raw_frame_at(int64_t frame, Pose& out) const;

  // --- commands (validated here, applied on the worker) ---
  void set_prompt(const std::string& text);                 // from now on
  void set_prompt_at(double time, const std::string& text); // from `time` on (a past time means now)
  void clear_prompt();                                      // no prompt from now on
  void clear_prompt_at(double time);
  // The prompt from `time` on is `text` (nullopt: none), and every prompt
  // queued after `time` is forgotten (a timeline replaced by another).
  void reset_prompts_at(double time, std::optional<std::string> text);

  ConstraintId add_waypoint(double time, double x, double z, std::optional<double> heading = std::nullopt);
  // Dense path at `speed` m/s along (x, z) points from start_time; smooth:
  // mouse-style clicks (linear interpolation, then smoothing).
  ConstraintId add_path(double start_time, const std::vector<glm::dvec2>& points, double speed, bool smooth = false);
  // Dense path, one (x, z) per model frame from start_time (headings: none or one per position).
  ConstraintId add_path_frames(double start_time, std::vector<glm::dvec2> positions,
                               std::vector<double> headings = {});
  // Full-body keyframe as world explicit features [M] (features.hpp layout).
  ConstraintId add_keyframe(double time, std::vector<double> features, bool include_root = true);
  // Full-body keyframe from a pose (local rotations and root position; the
  // world positions are recomputed by FK).
  ConstraintId add_keyframe_pose(double time, const Pose& pose, bool include_root = true);
  ConstraintId add_joint_target(const JointTargetSpec& target);
  // Foot contacts over [start_time, end_time); feet by contact joint name
  // (features.contact_joints; empty: all of them).
  ConstraintId add_contact(double start_time, double end_time, const std::vector<std::string>& feet,
                           double value = 1.0);
  // Any constraint with frames in model frames (validated).
  ConstraintId add_constraint(Constraint constraint);
  void remove_constraint(ConstraintId id);  // unknown or passed ids are ignored
  void clear_constraints();

  // Keyboard steering: target root velocity (m/s, world x and z); each
  // window gets a root path blending from the current velocity to it.
  void set_target_velocity(double vx, double vz);
  void clear_target_velocity();

  // Sampling settings of the windows to come (unset: unchanged);
  // path_guidance_scale in (0, 1] (WindowInput::path_guidance_scale),
  // text_only_guidance_scale in (0, 4] (WindowInput::text_only_guidance_scale).
  void set_sampling(std::optional<size_t> steps, std::optional<float> w_text, std::optional<float> w_con,
                    std::optional<float> path_guidance_scale = std::nullopt,
                    std::optional<float> text_only_guidance_scale = std::nullopt);

  // --- reports ---
  PlannerStats stats() const;
  std::vector<WindowRecord> window_log() const;  // the last 256 windows, oldest first
  std::vector<std::string> take_errors();        // the queued worker errors, oldest first; empties the queue
  bool pop_error(std::string& out);              // the oldest queued error
  std::string last_error() const;                // the most recent worker error ("" if none)

  // Blocks until the worker has applied every command and has nothing left
  // to do (no window in flight, none due), or `timeout_seconds` passed
  // (false). For tests, baking and tools; never from a game's frame loop.
  bool wait_idle(double timeout_seconds = 30.0) const;

 private:
  struct FrameBlock;
  struct FrameSpan {
    std::shared_ptr<const FrameBlock> block;
    int64_t begin = 0;
    int64_t end = 0;  // exclusive
  };
  struct Segment;
  struct MasterState;
  struct PromptCommand {
    int64_t frame = 0;
    bool now = false;
    std::optional<std::string> text;
    bool drop_later = false;  // forget the events after `frame` first
  };
  struct AddConstraintCommand {
    ConstraintId id = 0;
    Constraint constraint;
  };
  struct RemoveConstraintCommand {
    ConstraintId id = 0;
  };
  struct ClearConstraintsCommand {};
  struct VelocityCommand {
    std::optional<glm::dvec2> velocity;
  };
  struct SamplingCommand {
    std::optional<size_t> steps;
    std::optional<float> w_text;
    std::optional<float> w_con;
    std::optional<float> path_guidance_scale;
    std::optional<float> text_only_guidance_scale;
  };
  using Command = std::variant<PromptCommand, AddConstraintCommand, RemoveConstraintCommand,
                               ClearConstraintsCommand, VelocityCommand, SamplingCommand>;

  // caller side
  void push(Command command, bool asap);
  int64_t playhead_frame() const;  // floor of the playhead in model frames
  int64_t frame_of(double time, const char* what) const;
  // frame_at and raw_frame_at: the span that holds `frame`, filled shown or raw.
  bool find_frame(int64_t frame, Pose& out, bool raw) const;
  void fill_frame(const FrameSpan& span, int64_t frame, Pose& out) const;
  void fill_raw_frame(const FrameSpan& span, int64_t frame, Pose& out) const;
  void size_pose(Pose& out) const;  // the pose's arrays to this model's joints and contacts

  // worker side
  void worker_main();
  void apply(std::vector<Command>& commands);
  void apply_one(Command& command);
  void request_splice(int64_t frame);
  size_t rollout_future_frames_hint() const;
  bool run_window();
  void maintain();
  bool work_due() const;
  int64_t earliest_splice() const;
  int64_t latency_frames() const;
  double latency_estimate() const;
  // False (nothing changed) when the window is late: a splice the playhead
  // has reached. Checked under the frame lock, so no sampled frame changes.
  bool publish(int64_t start, bool splice, size_t tokens, Rollout before, Rollout after,
               std::shared_ptr<const WindowResult> result, uint64_t window_id);
  Rollout rollout_at(int64_t frame) const;
  // The last segment starting before `frame` (the one that shows frame - 1), or null.
  const Segment* segment_before(int64_t frame) const;
  void report_error(const std::string& message);
  void record(const WindowRecord& record);
  double now() const;

  std::shared_ptr<const ModelPackage> package_;
  PlannerConfig config_;
  double fps_ = 0.0;
  int64_t patch_ = 0;
  size_t joints_ = 0;
  double smoothing_frames_ = 0.0;  // the output filter's sigma
  std::vector<float> initial_shown_;  // the output filter's context before frame 0 (initial_history's end)
  std::optional<FootLocker> foot_locker_;  // set when config_.foot_lock and the skeleton has legs
  size_t contacts_ = 0;

  // Shared with the caller.
  mutable std::mutex inbox_mutex_;  // inbox_, flags below; worker condition
  std::condition_variable wake_;
  mutable std::condition_variable idle_;
  std::vector<Command> inbox_;
  bool stop_ = false;
  bool low_signal_ = false;  // the caller saw the queue below the low-water mark
  bool busy_ = false;        // the worker is applying commands or running a window
  bool due_ = false;         // the worker has more to do right away
  std::atomic<bool> stopping_{false};
  std::atomic<bool> asap_pending_{false};  // a command in the inbox asks for a splice now

  std::atomic<double> playhead_{0.0};       // seconds; written under frames_mutex_
  std::atomic<double> underrun_{0.0};       // seconds
  std::atomic<int64_t> frames_end_{0};      // one past the last generated frame
  std::atomic<int64_t> low_water_frames_{0};
  std::atomic<uint64_t> next_constraint_id_{1};
  std::atomic<size_t> future_frames_{0};    // future goal horizon of a window, frames

  mutable std::mutex frames_mutex_;  // spans_ (written by the worker only)
  std::vector<FrameSpan> spans_;     // contiguous, in frame order

  mutable std::mutex report_mutex_;  // errors_, log_, stats_
  std::deque<std::string> errors_;
  std::string last_error_;
  std::deque<WindowRecord> log_;
  PlannerStats stats_;

  // Worker only.
  std::unique_ptr<MasterState> master_;
  std::unique_ptr<MasterState> last_good_;
  std::vector<Segment> segments_;
  std::unique_ptr<Rollout> rollout_;  // the committed state: every queued frame
  NoiseGenerator noise_;
  std::optional<int64_t> splice_request_;  // earliest frame a window is asked to start at
  size_t pending_commands_ = 0;
  size_t failures_in_a_row_ = 0;
  std::deque<double> latencies_;
  std::atomic<double> latency_estimate_{0.0};
  uint64_t next_window_id_ = 1;

  std::thread worker_;  // last: started when everything above exists
};

}  // namespace ardy
