#include "sampler.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>

#include <glm/geometric.hpp>

#include "kinematics.hpp"

namespace ardy {
namespace {

constexpr float kGramSchmidtEps = 1e-8f;

std::string shape_text(const std::vector<int64_t>& shape) {
  std::string out = "[";
  for (size_t i = 0; i < shape.size(); ++i) out += (i ? ", " : "") + std::to_string(shape[i]);
  return out + "]";
}

void check_finite_output(const std::string& graph, const std::string& output, const std::vector<float>& values) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      throw Error(graph + ": output '" + output + "' element " + std::to_string(i) + " is " +
                  (std::isnan(values[i]) ? "NaN" : "infinite") + " (the model produced a non-finite value)");
    }
  }
}

void check_cancel(const CancelCheck& cancel) {
  if (cancel && cancel()) throw Cancelled();
}

// The sizes every window of a batch is checked against.
void check_window(const ModelPackage& package, const WindowInput& w, const std::vector<float>& noise,
                  const std::string& where) {
  const TokenSizes& t = package.tokens();
  const size_t c = t.window, d = t.token_dim;
  if (w.history.size() != w.history_tokens * d) {
    throw Error(where + ": history has " + std::to_string(w.history.size()) +
                " values, expected history_tokens * D = " + std::to_string(w.history_tokens) + " * " +
                std::to_string(d));
  }
  if (w.history_tokens > t.max_history) {
    throw Error(where + ": " + std::to_string(w.history_tokens) +
                " history tokens, more than the model's max_history (" + std::to_string(t.max_history) + ")");
  }
  const WindowGoals& g = w.goals;
  if (g.window_tokens != c || g.goal_dim != t.goal_dim || g.window_goal.size() != c * t.goal_dim ||
      g.window_goal_mask.size() != c * t.goal_dim) {
    throw Error(where + ": window goals are for " + std::to_string(g.window_tokens) + " tokens of " +
                std::to_string(g.goal_dim) + " entries, the model needs " + std::to_string(c) + " of " +
                std::to_string(t.goal_dim));
  }
  if (g.future_goal.size() != g.future_tokens * t.goal_dim ||
      g.future_goal_mask.size() != g.future_tokens * t.goal_dim || g.future_mask.size() != g.future_tokens) {
    throw Error(where + ": future goals do not hold " + std::to_string(g.future_tokens) + " tokens");
  }
  if (g.future_tokens > t.max_future) {
    throw Error(where + ": " + std::to_string(g.future_tokens) +
                " future goal tokens, more than the model's max_future (" + std::to_string(t.max_future) + ")");
  }
  if (noise.size() != c * d) {
    throw Error(where + ": noise has " + std::to_string(noise.size()) +
                " values, expected C * D = " + std::to_string(c * d));
  }
  if (w.text_embedding && w.text_embedding->size() != package.text_embedding_size()) {
    throw Error(where + ": text embedding has " + std::to_string(w.text_embedding->size()) + " values, expected " +
                std::to_string(package.text_embedding_size()));
  }
  const size_t n = package.schedule().num_steps();
  if (w.steps < 1 || w.steps > n) {
    throw Error(where + ": steps is " + std::to_string(w.steps) + ", expected 1.." + std::to_string(n) +
                " (the schedule's diffusion.num_steps)");
  }
  if (!std::isfinite(w.w_text) || !std::isfinite(w.w_con)) {
    throw Error(where + ": guidance weights must be finite (w_text " + std::to_string(w.w_text) + ", w_con " +
                std::to_string(w.w_con) + ")");
  }
  if (!path_guidance_scale_in_range(w.path_guidance_scale)) {
    throw Error(where + ": path_guidance_scale is " + std::to_string(w.path_guidance_scale) + ", expected (0, 1]");
  }
  if (!text_only_guidance_scale_in_range(w.text_only_guidance_scale)) {
    throw Error(where + ": text_only_guidance_scale is " + std::to_string(w.text_only_guidance_scale) +
                ", expected (0, 4]");
  }
}

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

}  // namespace

// --- diffusion --------------------------------------------------------------------

std::vector<int64_t> ddim_timesteps(size_t num_train_steps, size_t steps) {
  if (steps < 1 || steps > num_train_steps) {
    throw Error("DDIM steps must be in 1.." + std::to_string(num_train_steps) + ", got " + std::to_string(steps));
  }
  const auto n = static_cast<int64_t>(num_train_steps);
  const auto s = static_cast<int64_t>(steps);
  if (s == 1) return {n - 1};
  std::vector<int64_t> out;
  out.reserve(steps);
  for (int64_t i = 0; i < s; ++i) out.push_back(((n - 1) * (s - 1 - i) * 2 + (s - 1)) / (2 * (s - 1)));
  return out;
}

std::pair<float, float> ddim_coefficients(const DiffusionSchedule& schedule, int64_t t) {
  if (t < 0 || static_cast<size_t>(t) >= schedule.num_steps()) {
    throw Error("diffusion timestep " + std::to_string(t) + " out of range 0.." +
                std::to_string(schedule.num_steps() - 1));
  }
  const double ab = schedule.alphas_cumprod[static_cast<size_t>(t)];
  return {static_cast<float>(std::sqrt(ab)), static_cast<float>(std::sqrt(1.0 - ab))};
}

// --- guidance ------------------------------------------------------------------------

std::vector<GuidanceRow> guidance_rows(float w_text, float late_w_text, float w_con, bool has_text,
                                       bool has_constraints) {
  const float wt = has_text ? w_text : 0.0f;
  const float late_wt = has_text ? late_w_text : 0.0f;
  const float wc = has_constraints ? w_con : 0.0f;
  // 1 - w_t - w_c as Python computes it (float64), then float32.
  const auto uncond_weight = [wc](float text_weight) {
    return static_cast<float>(1.0 - static_cast<double>(text_weight) - static_cast<double>(wc));
  };
  const GuidanceRow all[3] = {{"uncond", 0.0f, 0.0f, uncond_weight(wt), uncond_weight(late_wt)},
                              {"text", 1.0f, 0.0f, wt, late_wt},
                              {"constraint", 0.0f, 1.0f, wc, wc}};
  std::vector<GuidanceRow> out;
  for (const GuidanceRow& row : all) {
    if (row.weight != 0.0f || row.late_weight != 0.0f) out.push_back(row);
  }
  return out;
}

// --- noise ------------------------------------------------------------------------------

NoiseGenerator::NoiseGenerator(uint64_t seed) {
  uint64_t state = seed;
  for (uint64_t& s : s_) s = splitmix64(state);
}

uint64_t NoiseGenerator::next() {
  const uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double NoiseGenerator::uniform() { return (static_cast<double>(next() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }

void NoiseGenerator::fill(float* out, size_t count) {
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  for (size_t i = 0; i < count; ++i) {
    if (has_spare_) {
      has_spare_ = false;
      out[i] = static_cast<float>(spare_);
      continue;
    }
    const double r = std::sqrt(-2.0 * std::log(uniform()));
    const double theta = kTwoPi * uniform();
    spare_ = r * std::sin(theta);
    has_spare_ = true;
    out[i] = static_cast<float>(r * std::cos(theta));
  }
}

std::vector<float> NoiseGenerator::normal(size_t count) {
  std::vector<float> out(count);
  fill(out.data(), count);
  return out;
}

// --- DDIM -----------------------------------------------------------------------------------

namespace {

// Frames over which root continuity's height displacement returns to 0
// after the last constrained frame (0.5 s at the models' 20 fps).
constexpr size_t kHeightReturnFrames = 10;

// The in-window root overwrite of x0 [C, D] (sampler.py), and
// WindowInput::root_continuity when `continuous`.
void overwrite_root(const WindowInput& in, const FeatureLayout& layout, const TokenSizes& t, std::vector<float>& x0,
                    bool continuous) {
  const size_t d = t.token_dim, patch = t.patch, m = layout.feature_size, rs = layout.root_size();
  const size_t root_start = layout.root().start, frames = t.window * patch;
  const size_t position_begin = layout.root_position.start - root_start;
  const size_t position_end = position_begin + layout.root_position.size;
  // Root entry q of frame f: token entry (f / P) * D + (f % P) * rs + q; its
  // goal: entry (f / P) * P * M + (f % P) * M + root_start + q.
  const auto value_at = [&](size_t f, size_t q) -> float& { return x0[(f / patch) * d + (f % patch) * rs + q]; };
  const auto goal_index = [&](size_t f, size_t q) { return f * m + root_start + q; };
  for (size_t q = 0; q < rs; ++q) {
    if (!continuous || q < position_begin || q >= position_end) {
      for (size_t f = 0; f < frames; ++f) {
        const float v = in.goals.window_goal_mask[goal_index(f, q)];
        const float goal = in.goals.window_goal[goal_index(f, q)];
        float& value = value_at(f, q);
        const float kept = (1.0f - v) * value;
        const float set = v * goal;
        value = kept + set;
      }
      continue;
    }
    // Displacements: v * (goal - x0) at constrained frames, 0 before the
    // window, linear in between, held after the last constrained frame: the
    // ground position keeps it (a waypoint reached stays reached); the
    // height returns to the model's own over kHeightReturnFrames, so a
    // keyframe's hips height does not leave the body floating or sunk.
    const bool height = q == position_begin + 1;
    long long known = -1;
    float known_shift = 0.0f;
    size_t f = 0;
    while (f < frames) {
      size_t next = f;
      while (next < frames && !(in.goals.window_goal_mask[goal_index(next, q)] > 0.0f)) ++next;
      const bool found = next < frames;
      float next_shift = known_shift;
      if (found) {
        const float v = in.goals.window_goal_mask[goal_index(next, q)];
        next_shift = v * (in.goals.window_goal[goal_index(next, q)] - value_at(next, q));
      }
      for (size_t g = f; g < next; ++g) {
        const auto after = static_cast<float>(static_cast<long long>(g) - known);
        float shift = known_shift;
        if (found) {
          shift += after / static_cast<float>(static_cast<long long>(next) - known) * (next_shift - known_shift);
        } else if (height && known >= 0) {
          shift *= std::max(0.0f, 1.0f - after / static_cast<float>(kHeightReturnFrames + 1));
        }
        value_at(g, q) += shift;
      }
      if (!found) break;
      value_at(next, q) += next_shift;
      known = static_cast<long long>(next);
      known_shift = next_shift;
      f = next + 1;
    }
  }
}

// Every window's history keys and values, from one history graph call:
// [W, stages * layers, 2, heads, h_max, head_dim], each window's history
// right-aligned (padding first, masked).
struct HistoryKeysValues {
  size_t tokens = 0;                // h_max
  size_t values_per_window = 0;     // stages * layers * 2 * heads * h_max * head_dim
  std::vector<float> mask;          // [W, h_max]
  std::vector<float> keys_values;   // [W, ...]
  std::vector<int64_t> row_shape;   // the denoiser's history_kv shape without the batch axis
};

HistoryKeysValues history_keys_values(const ModelPackage& package, const std::vector<const WindowInput*>& windows,
                                      size_t h_max) {
  const size_t d = package.tokens().token_dim, count = windows.size();
  HistoryKeysValues out;
  out.tokens = h_max;
  std::vector<float> history(count * h_max * d, 0.0f);
  out.mask.assign(count * h_max, 0.0f);
  for (size_t w = 0; w < count; ++w) {
    const WindowInput& in = *windows[w];
    const size_t h = in.history_tokens;
    std::copy(in.history.begin(), in.history.end(), history.begin() + static_cast<std::ptrdiff_t>((w * h_max + h_max - h) * d));
    std::fill(out.mask.begin() + static_cast<std::ptrdiff_t>(w * h_max + h_max - h),
              out.mask.begin() + static_cast<std::ptrdiff_t>((w + 1) * h_max), 1.0f);
  }
  const auto wi = static_cast<int64_t>(count), hi = static_cast<int64_t>(h_max);
  const DenoiserSizes& sizes = package.denoiser_sizes();
  out.row_shape = {static_cast<int64_t>(sizes.cached_layers()), 2, static_cast<int64_t>(sizes.heads), hi,
                   static_cast<int64_t>(sizes.head_dim())};
  // Without history there is nothing to compute (and ONNX Reshape reads a 0
  // in a target shape as "keep this axis", so the graph cannot take H = 0).
  if (h_max == 0) return out;
  std::vector<std::pair<std::string, Tensor>> inputs;
  inputs.emplace_back("history", Tensor::float32({wi, hi, static_cast<int64_t>(d)}, std::move(history)));
  inputs.emplace_back("history_mask", Tensor::float32({wi, hi}, out.mask));
  Tensor result = std::move(package.history().run(inputs, {"history_kv"}).at(0));
  std::vector<int64_t> expected{wi};
  expected.insert(expected.end(), out.row_shape.begin(), out.row_shape.end());
  if (result.shape != expected) {
    throw Error(package.history().name() + ": output 'history_kv' has shape " + shape_text(result.shape) +
                ", expected " + shape_text(expected));
  }
  check_finite_output(package.history().name(), "history_kv", result.data);
  out.values_per_window = count ? result.data.size() / count : 0;
  out.keys_values = std::move(result.data);
  return out;
}

// What the goals of the windows with constraint rows contribute to every
// step, from one goals graph call: window_root_goal, window_root_mask
// [Wc, C, 5P], window_goal_embedding [Wc, stages, C, W], future_embedding
// [Wc, stages, F, W], with F the longest future of those windows.
struct GoalEmbeddings {
  std::vector<size_t> row_of;  // window -> its row in the outputs (only windows with a constraint row)
  size_t future = 0;
  std::vector<Tensor> outputs;  // kGoalOutputs order
};

const char* const kGoalOutputs[] = {"window_root_goal", "window_root_mask", "window_goal_embedding",
                                    "future_embedding"};

bool has_constraint_row(const std::vector<GuidanceRow>& rows) {
  return std::any_of(rows.begin(), rows.end(), [](const GuidanceRow& row) { return row.constraint_keep != 0.0f; });
}

GoalEmbeddings goal_embeddings(const ModelPackage& package, const std::vector<const WindowInput*>& windows,
                               const std::vector<std::vector<GuidanceRow>>& rows_of) {
  const TokenSizes& t = package.tokens();
  const size_t c = t.window, pm = t.goal_dim;
  GoalEmbeddings out;
  out.row_of.assign(windows.size(), 0);
  std::vector<size_t> members;
  for (size_t w = 0; w < windows.size(); ++w) {
    if (!has_constraint_row(rows_of[w])) continue;
    out.row_of[w] = members.size();
    members.push_back(w);
    out.future = std::max(out.future, windows[w]->goals.future_tokens);
  }
  if (members.empty()) return out;
  const size_t count = members.size(), f = out.future;
  std::vector<float> window_goal(count * c * pm), window_goal_mask(count * c * pm);
  std::vector<float> future_goal(count * f * pm, 0.0f), future_goal_mask(count * f * pm, 0.0f);
  for (size_t r = 0; r < count; ++r) {
    const WindowGoals& goals = windows[members[r]]->goals;
    std::copy(goals.window_goal.begin(), goals.window_goal.end(), window_goal.begin() + r * c * pm);
    std::copy(goals.window_goal_mask.begin(), goals.window_goal_mask.end(), window_goal_mask.begin() + r * c * pm);
    // Future at the front: padding at the back.
    std::copy(goals.future_goal.begin(), goals.future_goal.end(), future_goal.begin() + r * f * pm);
    std::copy(goals.future_goal_mask.begin(), goals.future_goal_mask.end(), future_goal_mask.begin() + r * f * pm);
  }
  const auto ri = static_cast<int64_t>(count), ci = static_cast<int64_t>(c), pmi = static_cast<int64_t>(pm);
  const auto fi = static_cast<int64_t>(f);
  std::vector<std::pair<std::string, Tensor>> inputs;
  inputs.emplace_back("window_goal", Tensor::float32({ri, ci, pmi}, std::move(window_goal)));
  inputs.emplace_back("window_goal_mask", Tensor::float32({ri, ci, pmi}, std::move(window_goal_mask)));
  inputs.emplace_back("future_goal", Tensor::float32({ri, fi, pmi}, std::move(future_goal)));
  inputs.emplace_back("future_goal_mask", Tensor::float32({ri, fi, pmi}, std::move(future_goal_mask)));
  out.outputs = package.goals().run(inputs, {std::begin(kGoalOutputs), std::end(kGoalOutputs)});
  const DenoiserSizes& sizes = package.denoiser_sizes();
  const auto si = static_cast<int64_t>(sizes.stages()), wi = static_cast<int64_t>(sizes.width);
  const auto root = static_cast<int64_t>(t.root_token_dim());
  const std::vector<int64_t> expected[] = {{ri, ci, root}, {ri, ci, root}, {ri, si, ci, wi}, {ri, si, fi, wi}};
  for (size_t i = 0; i < out.outputs.size(); ++i) {
    if (out.outputs[i].shape != expected[i]) {
      throw Error(package.goals().name() + ": output '" + kGoalOutputs[i] + "' has shape " +
                  shape_text(out.outputs[i].shape) + ", expected " + shape_text(expected[i]));
    }
    check_finite_output(package.goals().name(), kGoalOutputs[i], out.outputs[i].data);
  }
  return out;
}

// Guidance rows that share one denoiser call per step. Rows whose constraints
// are off (constraint_keep 0) ignore every goal and future token, so they go
// in a call with no future tokens and zero goal inputs: exact, since the
// graph masks those tokens out of their attention and multiplies the goals
// by constraint_keep, and future tokens are most of a window's tokens.
struct RowGroup {
  std::vector<std::pair<size_t, size_t>> members;  // (window, guidance row) per batch row
  std::unique_ptr<RepeatedRun> run;
  Tensor output;
};

RowGroup make_row_group(const ModelPackage& package, const std::vector<const WindowInput*>& windows,
                        const std::vector<std::vector<GuidanceRow>>& rows_of, const HistoryKeysValues& history,
                        const GoalEmbeddings& goals, bool constrained) {
  const TokenSizes& t = package.tokens();
  const DenoiserSizes& sizes = package.denoiser_sizes();
  const size_t c = t.window, d = t.token_dim, e = package.text_embedding_size(), root = t.root_token_dim();
  const size_t stages = sizes.stages(), width = sizes.width;
  RowGroup group;
  for (size_t w = 0; w < windows.size(); ++w) {
    for (size_t k = 0; k < rows_of[w].size(); ++k) {
      if ((rows_of[w][k].constraint_keep != 0.0f) == constrained) group.members.emplace_back(w, k);
    }
  }
  const size_t rows = group.members.size();
  if (rows == 0) return group;
  const size_t f = constrained ? goals.future : 0;
  const size_t h_max = history.tokens, kv = history.values_per_window;
  const size_t root_values = c * root, window_values = stages * c * width, future_values = stages * f * width;
  std::vector<float> text_embedding(rows * e, 0.0f), text_keep(rows, 0.0f), constraint_keep(rows, 0.0f);
  std::vector<float> keys_values(rows * kv), history_mask(rows * h_max);
  std::vector<float> root_goal(rows * root_values, 0.0f), root_mask(rows * root_values, 0.0f);
  std::vector<float> window_embedding(rows * window_values, 0.0f), future_embedding(rows * future_values, 0.0f);
  std::vector<float> future_mask(rows * f, 0.0f);
  for (size_t r = 0; r < rows; ++r) {
    const auto [w, k] = group.members[r];
    const WindowInput& in = *windows[w];
    const GuidanceRow& row = rows_of[w][k];
    if (in.text_embedding) std::copy(in.text_embedding->begin(), in.text_embedding->end(), text_embedding.begin() + r * e);
    text_keep[r] = row.text_keep;
    constraint_keep[r] = row.constraint_keep;
    std::copy_n(history.keys_values.begin() + static_cast<std::ptrdiff_t>(w * kv), kv, keys_values.begin() + r * kv);
    std::copy_n(history.mask.begin() + static_cast<std::ptrdiff_t>(w * h_max), h_max, history_mask.begin() + r * h_max);
    if (!constrained) continue;  // the graph zeroes the goals of rows with constraint_keep 0
    const size_t g = goals.row_of[w];
    const auto copy_block = [&](size_t output, size_t values, std::vector<float>& to) {
      std::copy_n(goals.outputs[output].data.begin() + static_cast<std::ptrdiff_t>(g * values), values,
                  to.begin() + static_cast<std::ptrdiff_t>(r * values));
    };
    copy_block(0, root_values, root_goal);
    copy_block(1, root_values, root_mask);
    copy_block(2, window_values, window_embedding);
    copy_block(3, future_values, future_embedding);
    // Future at the front: padding at the back (masked).
    std::copy(in.goals.future_mask.begin(), in.goals.future_mask.end(), future_mask.begin() + r * f);
  }
  const auto ri = static_cast<int64_t>(rows), ci = static_cast<int64_t>(c), si = static_cast<int64_t>(stages);
  const auto hi = static_cast<int64_t>(h_max), fi = static_cast<int64_t>(f), wi = static_cast<int64_t>(width);
  const auto rooti = static_cast<int64_t>(root);
  std::vector<int64_t> kv_shape{ri};
  kv_shape.insert(kv_shape.end(), history.row_shape.begin(), history.row_shape.end());
  std::vector<std::pair<std::string, Tensor>> inputs;
  inputs.reserve(12);
  inputs.emplace_back("x_t", Tensor::float32({ri, ci, static_cast<int64_t>(d)}, std::vector<float>(rows * c * d, 0.0f)));
  inputs.emplace_back("step", Tensor::int64({ri}, std::vector<int64_t>(rows, 0)));
  inputs.emplace_back("text_embedding", Tensor::float32({ri, static_cast<int64_t>(e)}, std::move(text_embedding)));
  inputs.emplace_back("text_keep", Tensor::float32({ri}, std::move(text_keep)));
  inputs.emplace_back("history_kv", Tensor::float32(std::move(kv_shape), std::move(keys_values)));
  inputs.emplace_back("history_mask", Tensor::float32({ri, hi}, std::move(history_mask)));
  inputs.emplace_back("window_root_goal", Tensor::float32({ri, ci, rooti}, std::move(root_goal)));
  inputs.emplace_back("window_root_mask", Tensor::float32({ri, ci, rooti}, std::move(root_mask)));
  inputs.emplace_back("window_goal_embedding", Tensor::float32({ri, si, ci, wi}, std::move(window_embedding)));
  inputs.emplace_back("future_embedding", Tensor::float32({ri, si, fi, wi}, std::move(future_embedding)));
  inputs.emplace_back("future_mask", Tensor::float32({ri, fi}, std::move(future_mask)));
  inputs.emplace_back("constraint_keep", Tensor::float32({ri}, std::move(constraint_keep)));
  group.run = std::make_unique<RepeatedRun>(package.denoiser(), std::move(inputs), std::vector<std::string>{"x0"});
  return group;
}

}  // namespace

std::vector<std::vector<float>> sample_windows(const ModelPackage& package,
                                               const std::vector<const WindowInput*>& windows,
                                               const std::vector<const std::vector<float>*>& noises,
                                               const CancelCheck& cancel) {
  if (windows.empty()) return {};
  if (noises.size() != windows.size()) {
    throw Error("sample_windows: " + std::to_string(windows.size()) + " windows but " + std::to_string(noises.size()) +
                " noise tensors");
  }
  for (size_t w = 0; w < windows.size(); ++w) {
    if (windows[w] == nullptr || noises[w] == nullptr)
      throw Error("sample_windows: window " + std::to_string(w) + " is null");
    check_window(package, *windows[w], *noises[w], "window " + std::to_string(w));
    if (windows[w]->steps != windows[0]->steps) {
      throw Error("sample_windows: window " + std::to_string(w) + " uses " + std::to_string(windows[w]->steps) +
                  " steps, window 0 uses " + std::to_string(windows[0]->steps) + " (a batch shares its steps)");
    }
  }
  const TokenSizes& t = package.tokens();
  const FeatureLayout& layout = package.layout();
  const size_t c = t.window, d = t.token_dim;
  const size_t cd = c * d;

  std::vector<std::vector<GuidanceRow>> rows_of;
  size_t h_max = 0;
  for (const WindowInput* w : windows) {
    const bool has_goals = w->goals.has_constraints();
    const float w_con = w->goals.root_path_only ? w->w_con * w->path_guidance_scale : w->w_con;
    const float w_text = has_goals ? w->w_text : w->w_text * w->text_only_guidance_scale;
    rows_of.push_back(guidance_rows(w_text, w->w_text, w_con, w->text_embedding.has_value(), has_goals));
    if (rows_of.back().empty()) {
      // A guard: the weights sum to 1, so at least one row remains.
      throw Error("sample_windows: the guidance weights leave no denoiser row (w_text " + std::to_string(w->w_text) +
                  ", w_con " + std::to_string(w->w_con) + ")");
    }
    h_max = std::max(h_max, w->history_tokens);
  }

  check_cancel(cancel);
  // The history and goals graphs read different inputs: run them at once.
  auto goals_call = std::async(std::launch::async, [&] { return goal_embeddings(package, windows, rows_of); });
  const HistoryKeysValues history = history_keys_values(package, windows, h_max);
  const GoalEmbeddings goals = goals_call.get();
  std::vector<RowGroup> groups;
  for (const bool constrained : {false, true}) {
    RowGroup group = make_row_group(package, windows, rows_of, history, goals, constrained);
    if (!group.members.empty()) groups.push_back(std::move(group));
  }

  std::vector<std::vector<float>> x;  // current x_t of each window
  x.reserve(windows.size());
  for (const std::vector<float>* noise : noises) x.push_back(*noise);
  std::vector<std::vector<float>> x0(windows.size(), std::vector<float>(cd, 0.0f));

  const std::vector<int64_t> timesteps = ddim_timesteps(package.schedule().num_steps(), windows[0]->steps);
  // row_x0[w][k]: guidance row k of window w in its group's output of this step.
  std::vector<std::vector<const float*>> row_x0(windows.size());
  for (size_t w = 0; w < windows.size(); ++w) row_x0[w].resize(rows_of[w].size(), nullptr);
  for (size_t i = 0; i < timesteps.size(); ++i) {
    for (RowGroup& group : groups) {
      std::vector<float>& x_rows = group.run->values("x_t");
      for (size_t r = 0; r < group.members.size(); ++r) {
        const std::vector<float>& xt = x[group.members[r].first];
        std::copy(xt.begin(), xt.end(), x_rows.begin() + static_cast<std::ptrdiff_t>(r * cd));
      }
      std::vector<int64_t>& steps = group.run->int64_values("step");
      std::fill(steps.begin(), steps.end(), timesteps[i]);
    }
    check_cancel(cancel);
    // The two calls of a step are independent: run them at once (measured in
    // bench/: the full case's window about 1.3x faster on 2 cores).
    if (groups.size() == 2) {
      auto second = std::async(std::launch::async, [&] { return std::move(groups[1].run->run().at(0)); });
      Tensor first = std::move(groups[0].run->run().at(0));
      groups[1].output = second.get();
      groups[0].output = std::move(first);
    } else {
      for (RowGroup& group : groups) group.output = std::move(group.run->run().at(0));
    }
    for (RowGroup& group : groups) {
      const std::vector<int64_t> expected_shape{static_cast<int64_t>(group.members.size()), static_cast<int64_t>(c),
                                                static_cast<int64_t>(d)};
      if (group.output.shape != expected_shape) {
        throw Error(package.denoiser().name() + ": output 'x0' has shape " + shape_text(group.output.shape) +
                    ", expected " + shape_text(expected_shape));
      }
      for (size_t r = 0; r < group.members.size(); ++r) {
        const auto [w, k] = group.members[r];
        row_x0[w][k] = group.output.data.data() + r * cd;
      }
    }
    const bool late = is_late_step(timesteps[i], package.schedule().num_steps());
    for (size_t w = 0; w < windows.size(); ++w) {
      const WindowInput& in = *windows[w];
      std::vector<float>& result = x0[w];
      const std::vector<GuidanceRow>& brs = rows_of[w];
      const auto weight = [&](size_t b) { return late ? brs[b].late_weight : brs[b].weight; };
      // x0 = c_first * row_first + c_next * row_next + ... (float32, in order).
      const float* first = row_x0[w][0];
      const float first_weight = weight(0);
      for (size_t j = 0; j < cd; ++j) result[j] = first_weight * first[j];
      for (size_t b = 1; b < brs.size(); ++b) {
        const float* row = row_x0[w][b];
        const float row_weight = weight(b);
        for (size_t j = 0; j < cd; ++j) {
          const float term = row_weight * row[j];
          result[j] = result[j] + term;
        }
      }
      if (in.root_overwrite) {
        const bool last_step = i + 1 == timesteps.size();
        overwrite_root(in, layout, t, result, in.root_continuity && last_step);
      }
    }
    if (i + 1 < timesteps.size()) {
      const auto [a, b] = ddim_coefficients(package.schedule(), timesteps[i]);
      const auto [a_next, b_next] = ddim_coefficients(package.schedule(), timesteps[i + 1]);
      for (size_t w = 0; w < windows.size(); ++w) {
        std::vector<float>& xt = x[w];
        const std::vector<float>& clean = x0[w];
        for (size_t j = 0; j < cd; ++j) {
          const float scaled = a * clean[j];
          const float eps = (xt[j] - scaled) / b;
          const float signal = a_next * clean[j];
          const float noise = b_next * eps;
          xt[j] = signal + noise;
        }
      }
    }
  }
  for (const std::vector<float>& result : x0) check_finite_output(package.denoiser().name(), "x0", result);
  return x0;
}

// --- decoding and poses ----------------------------------------------------------------------

std::vector<float> decode_window(const ModelPackage& package, const float* context, size_t context_tokens,
                                 const std::vector<float>& window, const float* prev_root) {
  const TokenSizes& t = package.tokens();
  const FeatureLayout& layout = package.layout();
  const size_t c = t.window, d = t.token_dim, rs = layout.root_size(), bs = layout.body_size();
  if (window.size() != c * d) {
    throw Error("decode_window: window has " + std::to_string(window.size()) +
                " values, expected C * D = " + std::to_string(c * d));
  }
  if (context_tokens > 0 && context == nullptr) throw Error("decode_window: context tokens without data");
  const size_t count = context_tokens + c;
  std::vector<float> tokens(count * d);
  if (context_tokens) std::copy(context, context + context_tokens * d, tokens.begin());
  std::copy(window.begin(), window.end(), tokens.begin() + context_tokens * d);
  std::vector<float> prev(rs, 0.0f);
  if (prev_root) std::copy(prev_root, prev_root + rs, prev.begin());
  std::vector<std::pair<std::string, Tensor>> inputs;
  inputs.emplace_back("tokens",
                      Tensor::float32({1, static_cast<int64_t>(count), static_cast<int64_t>(d)}, std::move(tokens)));
  inputs.emplace_back("prev_root", Tensor::float32({1, static_cast<int64_t>(rs)}, std::move(prev)));
  inputs.emplace_back("prev_root_valid", Tensor::float32({1}, {prev_root ? 1.0f : 0.0f}));
  const std::vector<Tensor> out = package.decoder().run(inputs, {"body"});
  const Tensor& body = out.at(0);
  const std::vector<int64_t> expected{1, static_cast<int64_t>(count * t.patch), static_cast<int64_t>(bs)};
  if (body.shape != expected) {
    throw Error(package.decoder().name() + ": output 'body' has shape " + shape_text(body.shape) + ", expected " +
                shape_text(expected));
  }
  check_finite_output(package.decoder().name(), "body", body.data);
  const size_t keep = c * t.patch * bs;
  return std::vector<float>(body.data.end() - static_cast<std::ptrdiff_t>(keep), body.data.end());
}

std::vector<float> window_features(const ModelPackage& package, const std::vector<float>& tokens,
                                   const std::vector<float>& body, const glm::dvec2& offset) {
  const TokenSizes& t = package.tokens();
  const FeatureLayout& layout = package.layout();
  const size_t c = t.window, d = t.token_dim, patch = t.patch, m = layout.feature_size;
  const size_t rs = layout.root_size(), bs = layout.body_size();
  const FeatureSlice root = layout.root(), body_slice = layout.body();
  const size_t frames = c * patch;
  if (tokens.size() != c * d || body.size() != frames * bs) {
    throw Error("window_features: " + std::to_string(tokens.size()) + " token values and " +
                std::to_string(body.size()) + " body values, expected " + std::to_string(c * d) + " and " +
                std::to_string(frames * bs));
  }
  std::vector<float> features(frames * m);
  for (size_t k = 0; k < c; ++k) {
    for (size_t p = 0; p < patch; ++p) {
      float* f = features.data() + (k * patch + p) * m;
      std::copy(tokens.begin() + k * d + p * rs, tokens.begin() + k * d + (p + 1) * rs, f + root.start);
      std::copy(body.begin() + (k * patch + p) * bs, body.begin() + (k * patch + p + 1) * bs, f + body_slice.start);
    }
  }
  package.feature_normalization().denormalize(features.data(), frames);
  const auto ox = static_cast<float>(offset.x), oz = static_cast<float>(offset.y);
  for (size_t f = 0; f < frames; ++f) {
    float* p = features.data() + f * m + layout.root_position.start;
    p[0] = p[0] + ox;
    p[2] = p[2] + oz;
  }
  return features;
}

glm::mat3 model_rotation_from_6d(const float* six) {
  const glm::vec3 a1(six[0], six[1], six[2]);
  glm::vec3 a2(six[3], six[4], six[5]);
  const float n1 = std::sqrt((a1.x * a1.x + a1.y * a1.y + a1.z * a1.z) + kGramSchmidtEps);
  const glm::vec3 b1 = a1 / n1;
  const float dot = b1.x * a2.x + b1.y * a2.y + b1.z * a2.z;
  a2 = a2 - dot * b1;
  const float n2 = std::sqrt((a2.x * a2.x + a2.y * a2.y + a2.z * a2.z) + kGramSchmidtEps);
  const glm::vec3 b2 = a2 / n2;
  const glm::vec3 b3(b1.y * b2.z - b1.z * b2.y, b1.z * b2.x - b1.x * b2.z, b1.x * b2.y - b1.y * b2.x);
  return glm::mat3(b1, b2, b3);
}

void features_to_motion(const Skeleton& skeleton, const FeatureLayout& layout, const float* features,
                        size_t frame_count, Motion& out) {
  const size_t j = skeleton.joint_count();
  if (layout.joint_count != j) {
    throw Error("features_to_motion: the layout has " + std::to_string(layout.joint_count) + " joints, the skeleton " +
                std::to_string(j));
  }
  out.frame_count = frame_count;
  out.joint_count = j;
  out.global_rotations.resize(frame_count * j);
  out.local_rotations.resize(frame_count * j);
  out.positions.resize(frame_count * j);
  std::vector<glm::mat3> global(j), local(j);
  std::vector<glm::vec3> positions(j);
  for (size_t f = 0; f < frame_count; ++f) {
    const float* row = features + f * layout.feature_size;
    for (size_t joint = 0; joint < j; ++joint) {
      global[joint] = model_rotation_from_6d(row + layout.rotation_6d.start + 6 * joint);
    }
    global_to_local(skeleton, global, local);
    const float* p = row + layout.root_position.start;
    joint_positions(skeleton, glm::vec3(p[0], p[1], p[2]), global, positions);
    std::copy(global.begin(), global.end(), out.global_rotations.begin() + f * j);
    std::copy(local.begin(), local.end(), out.local_rotations.begin() + f * j);
    std::copy(positions.begin(), positions.end(), out.positions.begin() + f * j);
  }
}

// --- whole windows --------------------------------------------------------------------------------

std::vector<WindowResult> generate_windows(const ModelPackage& package, const std::vector<const WindowInput*>& windows,
                                           const std::vector<const std::vector<float>*>& noises,
                                           const CancelCheck& cancel) {
  const std::vector<std::vector<float>> x0 = sample_windows(package, windows, noises, cancel);
  const TokenSizes& t = package.tokens();
  const size_t d = t.token_dim, rs = package.layout().root_size();
  std::vector<WindowResult> results;
  results.reserve(windows.size());
  for (size_t w = 0; w < windows.size(); ++w) {
    const WindowInput& in = *windows[w];
    check_cancel(cancel);
    const size_t h = in.history_tokens;
    const size_t k = std::min(h, in.decode_context_tokens);
    const float* context = in.history.data() + (h - k) * d;
    const float* prev_root = h >= k + 1 ? in.history.data() + (h - k - 1) * d + (t.patch - 1) * rs : nullptr;
    const std::vector<float> body = decode_window(package, k ? context : nullptr, k, x0[w], prev_root);
    WindowResult result;
    result.start_frame = in.start_frame;
    result.offset = in.offset;
    result.history_tokens = h;
    result.prompt = in.prompt;
    result.goal_mask = in.goals.window_goal_mask;
    result.frame_count = t.window * t.patch;
    result.tokens = x0[w];
    result.features = window_features(package, result.tokens, body, in.offset);
    features_to_motion(package.skeleton(), package.layout(), result.features.data(), result.frame_count, result.motion);
    results.push_back(std::move(result));
  }
  return results;
}

WindowResult generate_window(const ModelPackage& package, const WindowInput& window, const std::vector<float>& noise,
                             const CancelCheck& cancel) {
  std::vector<WindowResult> results = generate_windows(package, {&window}, {&noise}, cancel);
  return std::move(results.front());
}

}  // namespace ardy
