#pragma once

// One window of the model (docs/model_contract.md section 3, steps 4-9): the
// guidance rows, deterministic DDIM with the in-window root overwrite of the
// guided x0, decoding with history context, un-normalizing and un-centering,
// 6D -> rotations, global -> local rotations and forward kinematics. A batch
// of windows (several characters) shares one denoiser call per step, their
// rows concatenated.
//
// Pure: every function here depends only on its arguments (and the immutable
// ModelPackage); no clocks, no hidden state. sample_windows runs graph calls
// that do not depend on each other at once (std::async; the history and
// goals graphs, a step's two denoiser calls): the results do not depend on
// the timing. The port follows
// export_tools/ardy_export/sampling/{sampler,guidance}.py and diffusion.py
// operation by operation in float32, so results match the reference up to
// the graphs' own float differences. The autoregressive state around it is
// rollout.hpp.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "constraints.hpp"
#include "error.hpp"
#include "package.hpp"

namespace ardy {

// --- diffusion -----------------------------------------------------------------

// The timesteps a DDIM run with `steps` steps visits, noisiest first:
// t_i = ((N-1)(S-1-i)*2 + (S-1)) // (2(S-1)); S = 1: [N-1]. Error unless
// 1 <= steps <= num_train_steps.
std::vector<int64_t> ddim_timesteps(size_t num_train_steps, size_t steps);
// (float32(sqrt(ab[t])), float32(sqrt(1 - ab[t]))), computed in double.
std::pair<float, float> ddim_coefficients(const DiffusionSchedule& schedule, int64_t t);

// --- guidance ---------------------------------------------------------------------

// One denoiser row of a window (guidance.py Branch).
struct GuidanceRow {
  const char* name = "";  // "uncond", "text", "constraint"
  float text_keep = 0.0f;
  float constraint_keep = 0.0f;
  float weight = 0.0f;       // at the steps in the upper half of the schedule
  float late_weight = 0.0f;  // at the others (is_late_step)
};

// Rows D0, D_text, D_con in this order, each only if its weight or late
// weight is not exactly 0: w_t = w_text if has_text else 0, w_c = w_con if
// has_constraints else 0, D0 weight 1 - w_t - w_c; the late weights the same
// with late_w_text for w_text.
std::vector<GuidanceRow> guidance_rows(float w_text, float late_w_text, float w_con, bool has_text,
                                       bool has_constraints);
// The same weights at every step.
inline std::vector<GuidanceRow> guidance_rows(float w_text, float w_con, bool has_text, bool has_constraints) {
  return guidance_rows(w_text, w_text, w_con, has_text, has_constraints);
}

// Whether DDIM timestep t is in the lower half of a schedule of
// num_train_steps (t < num_train_steps / 2): the steps that settle the
// motion's detail once its content is decided. They combine the rows with
// their late weights.
inline bool is_late_step(int64_t t, size_t num_train_steps) {
  return 2 * t < static_cast<int64_t>(num_train_steps);
}

// --- cancellation -----------------------------------------------------------------

// Thrown when a CancelCheck asks to stop; nothing is committed.
class Cancelled : public Error {
 public:
  Cancelled() : Error("window generation cancelled") {}
};

// Asked before every denoiser and decoder call: true stops the window
// (Cancelled is thrown). Called on the thread that runs the window.
using CancelCheck = std::function<bool()>;

// --- noise ------------------------------------------------------------------------

// Seedable standard-normal float32 noise (xoshiro256** seeded by splitmix64,
// Box-Muller in double). The same seed gives the same numbers on every
// platform; copying the generator snapshots its state. (Not numpy's
// generator: goldens pass their noise explicitly.)
class NoiseGenerator {
 public:
  explicit NoiseGenerator(uint64_t seed = 0);
  void fill(float* out, size_t count);
  std::vector<float> normal(size_t count);

 private:
  uint64_t next();
  double uniform();  // (0, 1)
  uint64_t s_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// --- one window -------------------------------------------------------------------

// Everything a window needs, already in the model's frame (what a Rollout
// prepares; docs/model_contract.md steps 1-3).
struct WindowInput {
  int64_t start_frame = 0;
  glm::dvec2 offset{0.0};      // world (x, z) of the model frame's origin
  size_t history_tokens = 0;   // h
  std::vector<float> history;  // [h, D] normalized, re-centered, oldest first
  std::optional<std::string> prompt;
  std::optional<std::vector<float>> text_embedding;  // [E]; nullopt: no prompt (text row skipped)
  WindowGoals goals;
  // Sampling settings of this window.
  size_t steps = 4;
  float w_text = 2.0f;
  float w_con = 2.0f;
  // w_con is multiplied by this where the goals are a dense root path alone
  // (WindowGoals::root_path_only): guidance that pushes a fully given root
  // path harder makes the body over-commit to it, feet sliding under it.
  float path_guidance_scale = 1.0f;
  // w_text is multiplied by this where the window has a prompt and no goals,
  // at the steps in the upper half of the schedule (is_late_step false):
  // with goals the text and goal rows share the guidance, and a stronger text
  // row pulls the body off the goals; alone, the text can take more (the
  // prompt's motion is clearer and a new prompt shows sooner). The late
  // steps keep w_text: scaled there too, the feet flicked more often (at 1.5,
  // 6 against 1 of 40 continuity sessions; docs/evaluation/tried/README.md).
  float text_only_guidance_scale = 1.0f;
  bool root_overwrite = true;
  // With root_overwrite, after the last step: the root position entries the
  // goals leave free are moved too, by the overwrite's displacement
  // interpolated between constrained frames (0 at the frame before the
  // window; after the last constrained frame held on the ground (x, z) and
  // returning to 0 over 10 frames for the height). Where the model's own
  // root disagrees with the goals (it follows isolated targets poorly), the
  // root then has no step at the end of an overwritten stretch. Off in the
  // reference sampler (sampler.py), so the goldens' windows keep it off.
  bool root_continuity = false;
  size_t decode_context_tokens = 4;
};

// Poses of consecutive frames, flat per frame then joint.
struct Motion {
  size_t frame_count = 0;
  size_t joint_count = 0;
  std::vector<glm::mat3> global_rotations;  // [T * J] world rotations
  std::vector<glm::mat3> local_rotations;   // [T * J] parent-relative (root: world)
  std::vector<glm::vec3> positions;         // [T * J] world positions by FK

  const glm::mat3* global_rotations_of(size_t frame) const { return global_rotations.data() + frame * joint_count; }
  const glm::mat3* local_rotations_of(size_t frame) const { return local_rotations.data() + frame * joint_count; }
  const glm::vec3* positions_of(size_t frame) const { return positions.data() + frame * joint_count; }
};

struct WindowResult {
  int64_t start_frame = 0;
  glm::dvec2 offset{0.0};
  size_t history_tokens = 0;
  std::optional<std::string> prompt;
  std::vector<float> goal_mask;  // the window's goal mask, frame by frame [C * P, M] (what was constrained)
  size_t frame_count = 0;       // C * P
  std::vector<float> tokens;    // x0 [C, D]: normalized, model frame
  std::vector<float> features;  // [C * P, M]: world explicit features
  Motion motion;                // the same frames as poses
};

// DDIM for a batch of windows (sampler.py sample_windows). The history
// graph computes every window's history keys and values once, the goals
// graph what the goals of the windows with constraints contribute, once;
// then each step makes at most two denoiser calls: the rows without
// constraints (D0, D_text) of all windows with no future tokens and no goals,
// and the constraint rows with them (the graph ignores goals and future
// tokens in rows whose constraint_keep is 0, so this matches one call with
// every row). Inputs that do not change between steps are checked once. noises[i] is window i's initial noise [C, D]. Every
// window must use the same number of steps. Returns each window's clean
// tokens x0 [C, D] (normalized, model frame).
std::vector<std::vector<float>> sample_windows(const ModelPackage& package,
                                               const std::vector<const WindowInput*>& windows,
                                               const std::vector<const std::vector<float>*>& noises,
                                               const CancelCheck& cancel = {});

// Decodes [context; window] tokens (normalized, one model frame) and keeps
// the window's frames: normalized body [C * P, body]. prev_root [root size]
// (normalized) is the root of the frame before the first context token, or
// null when there is none.
std::vector<float> decode_window(const ModelPackage& package, const float* context, size_t context_tokens,
                                 const std::vector<float>& window, const float* prev_root);

// World features [C * P, M] from window tokens [C, D] and decoded body:
// x * std + mean, then + offset on p.x and p.z (float32).
std::vector<float> window_features(const ModelPackage& package, const std::vector<float>& tokens,
                                   const std::vector<float>& body, const glm::dvec2& offset);

// The contract's Gram-Schmidt (b1 = a1 / sqrt(|a1|^2 + 1e-8), the same for
// b2, b3 = b1 x b2), float32.
glm::mat3 model_rotation_from_6d(const float* six);

// Poses of `frame_count` frames of world features (6D -> rotations, local
// rotations, FK from the root position with the skeleton's rest offsets).
void features_to_motion(const Skeleton& skeleton, const FeatureLayout& layout, const float* features,
                        size_t frame_count, Motion& out);

// The whole window (steps 6-9): DDIM, decode with up to
// decode_context_tokens history tokens, features, poses.
WindowResult generate_window(const ModelPackage& package, const WindowInput& window, const std::vector<float>& noise,
                             const CancelCheck& cancel = {});
// Several windows (characters) with one denoiser call per step; decoding is
// one call per window.
std::vector<WindowResult> generate_windows(const ModelPackage& package, const std::vector<const WindowInput*>& windows,
                                           const std::vector<const std::vector<float>*>& noises,
                                           const CancelCheck& cancel = {});

// Generates one window: the real one is generate_window(). A planner takes
// one (PlannerConfig::generator); WindowBatcher makes one that batches
// several planners' windows; tests wrap it (delay, call counting, faults).
using WindowGenerator = std::function<WindowResult(const std::shared_ptr<const ModelPackage>&, const WindowInput&,
                                                   const std::vector<float>& noise, const CancelCheck&)>;

}  // namespace ardy
