#include "rollout.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace ardy {

std::optional<std::string> active_prompt(const std::vector<PromptEvent>& prompts, int64_t frame) {
  std::optional<std::string> text;
  bool found = false;
  int64_t best = 0;
  for (const PromptEvent& event : prompts) {
    if (event.frame <= frame && (!found || event.frame >= best)) {
      found = true;
      best = event.frame;
      text = event.text;
    }
  }
  return text;
}

Rollout::Rollout(std::shared_ptr<const ModelPackage> package, const RolloutSettings& settings)
    : package_(std::move(package)),
      constraints_(package_ ? package_->layout() : throw Error("Rollout: no model package given")),
      noise_(settings.seed) {
  config_ = resolve(settings);
}

RolloutConfig Rollout::resolve(const RolloutSettings& s) const {
  const ModelPackage& p = *package_;
  const TokenSizes& t = p.tokens();
  const SamplingDefaults& d = p.sampling_defaults();
  RolloutConfig c;
  c.steps = s.steps.value_or(d.steps);
  const size_t n = p.schedule().num_steps();
  if (c.steps < 1 || c.steps > n) {
    throw Error("rollout settings: steps is " + std::to_string(c.steps) + ", expected 1.." + std::to_string(n) +
                " (diffusion.num_steps of the package)");
  }
  c.w_text = s.w_text.value_or(d.w_text);
  c.w_con = s.w_con.value_or(d.w_con);
  if (!std::isfinite(c.w_text)) throw Error("rollout settings: w_text is not finite");
  if (!std::isfinite(c.w_con)) throw Error("rollout settings: w_con is not finite");
  c.history_tokens = std::min(s.history_tokens.value_or(t.max_history), t.max_history);
  c.future_tokens = std::min(s.future_tokens.value_or(t.max_future), t.max_future);
  c.decode_context_tokens = s.decode_context_tokens.value_or(d.decode_context_tokens);
  c.commit_tokens = s.commit_tokens.value_or(t.window);
  if (c.commit_tokens < 1 || c.commit_tokens > t.window) {
    throw Error("rollout settings: commit_tokens is " + std::to_string(c.commit_tokens) + ", expected 1.." +
                std::to_string(t.window) + " (tokens.window)");
  }
  if (!std::isfinite(s.start_xz.x) || !std::isfinite(s.start_xz.y)) {
    throw Error("rollout settings: start_xz is not finite");
  }
  c.start_xz = s.start_xz;
  c.root_overwrite = s.root_overwrite;
  c.root_continuity = s.root_continuity;
  c.interpolate_root = s.interpolate_root.value_or(d.interpolate_root);
  c.path_guidance_scale = s.path_guidance_scale.value_or(d.path_guidance_scale);
  if (!path_guidance_scale_in_range(c.path_guidance_scale)) {
    throw Error("rollout settings: path_guidance_scale is " + std::to_string(c.path_guidance_scale) +
                ", expected (0, 1]");
  }
  c.text_only_guidance_scale = s.text_only_guidance_scale.value_or(d.text_only_guidance_scale);
  if (!text_only_guidance_scale_in_range(c.text_only_guidance_scale)) {
    throw Error("rollout settings: text_only_guidance_scale is " + std::to_string(c.text_only_guidance_scale) +
                ", expected (0, 4]");
  }
  if (!std::isfinite(s.max_root_speed) || s.max_root_speed < 0.0) {
    throw Error("rollout settings: max_root_speed is " + std::to_string(s.max_root_speed) +
                ", expected >= 0 m/s (0: no limit)");
  }
  c.max_root_speed = s.max_root_speed;
  c.seed = s.seed;
  return c;
}

void Rollout::configure(const RolloutSettings& settings) {
  RolloutConfig next = resolve(settings);
  if (next.seed != config_.seed) noise_ = NoiseGenerator(next.seed);
  config_ = next;
}

// --- prompts ---------------------------------------------------------------------

void Rollout::add_prompt(int64_t frame, std::optional<std::string> text) {
  if (text) package_->text_encoder().normalize_prompt(*text);  // throws for a bad prompt
  prompts_.push_back(PromptEvent{frame, std::move(text)});
}

void Rollout::clear_prompts() { prompts_.clear(); }

// --- state -------------------------------------------------------------------------

int64_t Rollout::next_frame() const {
  return first_frame_ + static_cast<int64_t>(committed_ * package_->tokens().patch);
}

size_t Rollout::stored_tokens() const { return latents_.size() / package_->tokens().latent_dim; }

glm::dvec2 Rollout::next_offset() const {
  const size_t h = std::min(stored_tokens(), config_.history_tokens);
  if (h == 0) return config_.start_xz;
  const size_t rs = package_->layout().root_size();
  const float* last = world_roots_.data() + world_roots_.size() - rs;
  return glm::dvec2(last[0], last[2]);
}

std::optional<std::vector<float>> Rollout::last_root() const {
  if (world_roots_.empty()) return std::nullopt;
  const size_t rs = package_->layout().root_size();
  return std::vector<float>(world_roots_.end() - static_cast<std::ptrdiff_t>(rs), world_roots_.end());
}

std::optional<glm::dvec2> Rollout::last_root_velocity() const {
  const size_t rs = package_->layout().root_size();
  if (world_roots_.size() < 2 * rs) return std::nullopt;
  const float* last = world_roots_.data() + world_roots_.size() - rs;
  const float* before = last - rs;
  const double fps = package_->fps();
  return glm::dvec2((double(last[0]) - double(before[0])) * fps, (double(last[2]) - double(before[2])) * fps);
}

void Rollout::reset(const glm::dvec2& start_xz) {
  if (!std::isfinite(start_xz.x) || !std::isfinite(start_xz.y)) throw Error("Rollout::reset: start_xz is not finite");
  config_.start_xz = start_xz;
  first_frame_ = 0;
  committed_ = 0;
  world_roots_.clear();
  latents_.clear();
}

void Rollout::append_tokens(const float* world_roots, const float* latents, size_t count) {
  const TokenSizes& t = package_->tokens();
  const size_t root_values = t.patch * package_->layout().root_size();
  world_roots_.insert(world_roots_.end(), world_roots, world_roots + count * root_values);
  latents_.insert(latents_.end(), latents, latents + count * t.latent_dim);
  committed_ += count;
  const size_t stored = stored_tokens();
  if (stored > t.max_history) {
    const size_t drop = stored - t.max_history;
    world_roots_.erase(world_roots_.begin(), world_roots_.begin() + static_cast<std::ptrdiff_t>(drop * root_values));
    latents_.erase(latents_.begin(), latents_.begin() + static_cast<std::ptrdiff_t>(drop * t.latent_dim));
  }
}

void Rollout::seed_history(const std::vector<float>& world_features, size_t frames, const CancelCheck& cancel) {
  const ModelPackage& p = *package_;
  const TokenSizes& t = p.tokens();
  const FeatureLayout& layout = p.layout();
  const size_t m = layout.feature_size, bs = layout.body_size(), rs = layout.root_size();
  if (frames == 0 || frames % t.patch != 0) {
    throw Error("Rollout::seed_history: " + std::to_string(frames) +
                " frames, expected a positive multiple of the patch size " + std::to_string(t.patch));
  }
  if (world_features.size() != frames * m) {
    throw Error("Rollout::seed_history: " + std::to_string(world_features.size()) + " values for " +
                std::to_string(frames) + " frames of " + std::to_string(m) + " features");
  }
  for (size_t i = 0; i < world_features.size(); ++i) {
    if (!std::isfinite(world_features[i])) {
      throw Error("Rollout::seed_history: feature " + std::to_string(i % m) + " of frame " + std::to_string(i / m) +
                  " is not finite");
    }
  }
  if (cancel && cancel()) throw Cancelled();
  const FeatureSlice body = layout.body(), root = layout.root();
  std::vector<float> normalized(frames * bs);
  std::vector<float> roots(frames * rs);
  for (size_t f = 0; f < frames; ++f) {
    const float* row = world_features.data() + f * m;
    std::copy(row + body.start, row + body.stop(), normalized.begin() + f * bs);
    std::copy(row + root.start, row + root.stop(), roots.begin() + f * rs);
  }
  p.feature_normalization().normalize(normalized.data(), frames, body);
  std::vector<std::pair<std::string, Tensor>> inputs;
  inputs.emplace_back(
      "body", Tensor::float32({1, static_cast<int64_t>(frames), static_cast<int64_t>(bs)}, std::move(normalized)));
  const std::vector<Tensor> out = p.encoder().run(inputs, {"latent"});
  const size_t count = frames / t.patch;
  const std::vector<int64_t> expected{1, static_cast<int64_t>(count), static_cast<int64_t>(t.latent_dim)};
  if (out.at(0).shape != expected) {
    throw Error(p.encoder().name() + ": output 'latent' has an unexpected shape for " + std::to_string(frames) +
                " frames");
  }
  for (float v : out.at(0).data) {
    if (!std::isfinite(v)) throw Error(p.encoder().name() + ": output 'latent' is not finite");
  }
  world_roots_.clear();
  latents_.clear();
  committed_ = 0;
  first_frame_ = -static_cast<int64_t>(frames);
  append_tokens(roots.data(), out.at(0).data.data(), count);
}

// --- windows ---------------------------------------------------------------------------

WindowInput Rollout::prepare_window() const {
  const ModelPackage& p = *package_;
  const TokenSizes& t = p.tokens();
  const FeatureLayout& layout = p.layout();
  const Normalization& norm = p.feature_normalization();
  const size_t d = t.token_dim, rs = layout.root_size(), root_start = layout.root().start, rd = t.root_token_dim();

  WindowInput in;
  in.start_frame = next_frame();
  const size_t stored = stored_tokens();
  const size_t h = std::min(stored, config_.history_tokens);
  in.history_tokens = h;
  in.offset = next_offset();
  const auto ox = static_cast<float>(in.offset.x), oz = static_cast<float>(in.offset.y);
  in.history.resize(h * d);
  for (size_t i = 0; i < h; ++i) {
    const size_t token = stored - h + i;
    const float* root = world_roots_.data() + token * rd;
    float* out = in.history.data() + i * d;
    for (size_t j = 0; j < rd; ++j) {
      const size_t r = j % rs;
      float v = root[j];
      if (r == 0) v = v - ox;
      if (r == 2) v = v - oz;
      out[j] = (v - norm.mean()[root_start + r]) / norm.stddev()[root_start + r];
    }
    const float* latent = latents_.data() + token * t.latent_dim;
    std::copy(latent, latent + t.latent_dim, out + rd);
  }
  in.prompt = active_prompt(prompts_, in.start_frame);
  if (in.prompt) in.text_embedding = p.text_encoder().encode(*in.prompt);
  GoalSpec spec;
  spec.layout = &layout;
  spec.normalization = &norm;
  spec.patch = t.patch;
  spec.window_tokens = t.window;
  spec.future_limit_tokens = config_.future_tokens;
  spec.interpolate_root = config_.interpolate_root;
  spec.max_root_speed = config_.max_root_speed;
  spec.fps = p.fps();
  in.goals = window_goals(constraints_, in.start_frame, in.offset, spec);
  in.steps = config_.steps;
  in.w_text = config_.w_text;
  in.w_con = config_.w_con;
  in.path_guidance_scale = config_.path_guidance_scale;
  in.text_only_guidance_scale = config_.text_only_guidance_scale;
  in.root_overwrite = config_.root_overwrite;
  in.root_continuity = config_.root_continuity;
  in.decode_context_tokens = config_.decode_context_tokens;
  return in;
}

std::vector<float> Rollout::draw_noise() {
  const TokenSizes& t = package_->tokens();
  return noise_.normal(t.window * t.token_dim);
}

void Rollout::commit(const WindowResult& window, size_t tokens) {
  const ModelPackage& p = *package_;
  const TokenSizes& t = p.tokens();
  const FeatureLayout& layout = p.layout();
  if (window.start_frame != next_frame()) {
    throw Error("Rollout::commit: the window starts at frame " + std::to_string(window.start_frame) +
                " but the rollout's next window starts at frame " + std::to_string(next_frame()) + " (a stale window)");
  }
  if (tokens < 1 || tokens > t.window) {
    throw Error("Rollout::commit: " + std::to_string(tokens) + " tokens, expected 1.." + std::to_string(t.window));
  }
  const size_t m = layout.feature_size, rs = layout.root_size(), rd = t.root_token_dim(), d = t.token_dim;
  if (window.features.size() != t.window * t.patch * m || window.tokens.size() != t.window * d) {
    throw Error("Rollout::commit: the window's tensors do not have this package's sizes");
  }
  const size_t frames = tokens * t.patch;
  std::vector<float> roots(frames * rs);
  for (size_t f = 0; f < frames; ++f) {
    const float* row = window.features.data() + f * m + layout.root().start;
    std::copy(row, row + rs, roots.begin() + f * rs);
  }
  std::vector<float> latents(tokens * t.latent_dim);
  for (size_t k = 0; k < tokens; ++k) {
    std::copy(window.tokens.begin() + k * d + rd, window.tokens.begin() + (k + 1) * d,
              latents.begin() + k * t.latent_dim);
  }
  append_tokens(roots.data(), latents.data(), tokens);
  const int64_t now = next_frame();
  constraints_.drop_passed(now);
  // Prompt events at or before `now` other than the active one can never be
  // active again.
  size_t keep = prompts_.size();
  int64_t best = 0;
  for (size_t i = 0; i < prompts_.size(); ++i) {
    if (prompts_[i].frame <= now && (keep == prompts_.size() || prompts_[i].frame >= best)) {
      keep = i;
      best = prompts_[i].frame;
    }
  }
  std::vector<PromptEvent> kept;
  for (size_t i = 0; i < prompts_.size(); ++i) {
    if (i == keep || prompts_[i].frame > now) kept.push_back(std::move(prompts_[i]));
  }
  prompts_ = std::move(kept);
}

WindowResult Rollout::generate_next_window(const std::vector<float>& noise, const CancelCheck& cancel) {
  const WindowInput in = prepare_window();
  WindowResult result = generate_window(*package_, in, noise, cancel);
  commit(result, config_.commit_tokens);
  return result;
}

WindowResult Rollout::generate_next_window(const CancelCheck& cancel) {
  NoiseGenerator generator = noise_;  // advanced only when the window is committed
  const TokenSizes& t = package_->tokens();
  const std::vector<float> noise = generator.normal(t.window * t.token_dim);
  WindowResult result = generate_next_window(noise, cancel);
  noise_ = generator;
  return result;
}

}  // namespace ardy
