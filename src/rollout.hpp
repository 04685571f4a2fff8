#pragma once

// The autoregressive state of one character (docs/model_contract.md section
// 3, sampler.py rollout): committed tokens stored as world roots and
// normalized latents, the history crop, translation-only re-centering, a
// prompt timeline ("prompt A now, prompt B at frame t"), a constraint
// timeline, and the noise generator.
//
// A window is made in three separable steps, so a planner can run the
// expensive middle one on a worker thread, batch it with other characters'
// windows, cancel it, or throw it away:
//
//   WindowInput in = rollout.prepare_window();        // history, prompt, goals
//   std::vector<float> noise = rollout.draw_noise();  // advances the seed
//   WindowResult out = generate_window(rollout.package(), in, noise, cancel);
//   rollout.commit(out, tokens);                      // first `tokens` tokens
//
// generate_next_window() does all of it with commit_tokens. A Rollout is a
// plain value: copying it snapshots the whole state (the package is shared
// and immutable). It is not synchronized: one thread uses a given object.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "constraints.hpp"
#include "error.hpp"
#include "package.hpp"
#include "sampler.hpp"

namespace ardy {

struct PromptEvent {
  int64_t frame = 0;
  std::optional<std::string> text;  // nullopt: no prompt from this frame on
};

// The text of the last event at or before `frame` (ties: the later in the
// list); nullopt when there is none or it clears the prompt.
std::optional<std::string> active_prompt(const std::vector<PromptEvent>& prompts, int64_t frame);

// Unset fields take the package's defaults (sampling.*) or limits (tokens.*).
struct RolloutSettings {
  std::optional<size_t> steps;  // 1..diffusion.num_steps
  std::optional<float> w_text;
  std::optional<float> w_con;
  std::optional<size_t> history_tokens;  // clamped to tokens.max_history
  std::optional<size_t> future_tokens;   // clamped to tokens.max_future
  std::optional<size_t> decode_context_tokens;
  std::optional<size_t> commit_tokens;  // 1..window; default: the whole window
  glm::dvec2 start_xz{0.0, 0.0};        // model origin before any history
  bool root_overwrite = true;
  bool root_continuity = true;           // WindowInput::root_continuity
  std::optional<bool> interpolate_root;  // GoalSpec::interpolate_root; default: the package's
  std::optional<float> path_guidance_scale;  // WindowInput::path_guidance_scale; default: the package's
  std::optional<float> text_only_guidance_scale;  // WindowInput::text_only_guidance_scale; default: the package's
  double max_root_speed = kDefaultMaxRootSpeed;  // GoalSpec::max_root_speed (m/s; 0: no limit)
  uint64_t seed = 0;
};

// RolloutSettings with every value resolved.
struct RolloutConfig {
  size_t steps = 0;
  float w_text = 0.0f;
  float w_con = 0.0f;
  size_t history_tokens = 0;
  size_t future_tokens = 0;
  size_t decode_context_tokens = 0;
  size_t commit_tokens = 0;
  glm::dvec2 start_xz{0.0, 0.0};
  bool root_overwrite = true;
  bool root_continuity = true;
  bool interpolate_root = false;
  float path_guidance_scale = 1.0f;
  float text_only_guidance_scale = 1.0f;
  double max_root_speed = 0.0;
  uint64_t seed = 0;
};

class Rollout {
 public:
  // Error when a setting is out of range (steps, commit_tokens, non-finite
  // weights or start position).
  explicit Rollout(std::shared_ptr<const ModelPackage> package, const RolloutSettings& settings = {});

  const ModelPackage& package() const { return *package_; }
  const std::shared_ptr<const ModelPackage>& shared_package() const { return package_; }
  const RolloutConfig& config() const { return config_; }
  // Changes the settings for the windows to come (the seed restarts the
  // noise generator only when it changes). Error leaves the rollout as it was.
  void configure(const RolloutSettings& settings);

  // --- prompts ---
  // Adds "prompt `text` from `frame` on" (nullopt: no prompt). The text is
  // checked now (Error for an empty, too long or invalid UTF-8 prompt; the
  // timeline is unchanged).
  void add_prompt(int64_t frame, std::optional<std::string> text);
  void clear_prompts();
  const std::vector<PromptEvent>& prompts() const { return prompts_; }
  std::optional<std::string> prompt_at(int64_t frame) const { return active_prompt(prompts_, frame); }

  // --- constraints ---
  ConstraintTimeline& constraints() { return constraints_; }
  const ConstraintTimeline& constraints() const { return constraints_; }

  // --- committed state ---
  int64_t next_frame() const;                             // first frame of the next window
  size_t committed_tokens() const { return committed_; }  // all ever committed (seed included)
  size_t stored_tokens() const;                           // kept for history (at most tokens.max_history)
  const std::vector<float>& world_roots() const { return world_roots_; }  // [stored, P, 5] world
  const std::vector<float>& latents() const { return latents_; }          // [stored, L] normalized
  // World (x, z) the next window's model frame is centred on: the last
  // committed frame's root, or start_xz before any history.
  glm::dvec2 next_offset() const;
  // The last committed frame's world root (x, y, z, cos, sin) and its (x, z)
  // velocity in m/s (backward difference); nullopt before any history.
  std::optional<std::vector<float>> last_root() const;
  std::optional<glm::dvec2> last_root_velocity() const;

  // Forgets every committed token; the next window starts at frame 0 from
  // `start_xz` (prompts and constraints are kept).
  void reset(const glm::dvec2& start_xz);
  // Replaces the history with an animation: world features [frames, M]
  // (frames a positive multiple of P), encoded by the package's encoder. Its
  // tokens take the frames before 0, so the next window starts at frame 0.
  void seed_history(const std::vector<float>& world_features, size_t frames, const CancelCheck& cancel = {});

  // --- windows ---
  WindowInput prepare_window() const;  // steps 1-5 (encodes the prompt; cached)
  std::vector<float> draw_noise();     // [C, D] standard normal, advances the generator
  // Commits the first `tokens` tokens of a window made from prepare_window()
  // of this state; Error for a stale window (another start frame) or a count
  // outside 1..C. Also drops the constraints that are now in the past.
  void commit(const WindowResult& window, size_t tokens);
  // prepare + draw_noise (or the given noise [C, D]) + generate + commit
  // commit_tokens. Returns the whole window (commit count in the config).
  WindowResult generate_next_window(const CancelCheck& cancel = {});
  WindowResult generate_next_window(const std::vector<float>& noise, const CancelCheck& cancel = {});

 private:
  void append_tokens(const float* world_roots, const float* latents, size_t count);
  RolloutConfig resolve(const RolloutSettings& settings) const;

  std::shared_ptr<const ModelPackage> package_;
  RolloutConfig config_;
  std::vector<PromptEvent> prompts_;
  ConstraintTimeline constraints_;
  NoiseGenerator noise_;
  int64_t first_frame_ = 0;         // frame of committed token 0
  size_t committed_ = 0;            // tokens committed since first_frame_
  std::vector<float> world_roots_;  // the last stored tokens' roots
  std::vector<float> latents_;
};

}  // namespace ardy
