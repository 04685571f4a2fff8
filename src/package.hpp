#pragma once

// The model package (design.md section 6, docs/model_contract.md): model.json
// plus the ONNX graphs and the text encoder's vocabulary, loaded from a folder
// or from memory buffers (an engine passes the bytes it read from a packed
// archive). Everything the runtime needs about the model comes from here;
// nothing about it is hard-coded, so a package with another skeleton, window
// or latent size loads and runs.
//
// Loading validates model.json field by field (types, ranges, sizes that must
// agree: token_dim = 5 * patch + latent_dim, goal_dim = patch * features.size,
// statistics lengths, skeleton parents, feature layout, schedule length,
// sampling defaults, text settings) and every graph's real inputs and outputs
// against both model.json's signature and the tensor contract. Errors name
// the file and field with the expected and the found value, e.g.
// "model.json: tokens.token_dim is 30, expected 5*patch + latent_dim = 28".
//
// A ModelPackage is immutable once loaded and may be used from several
// threads at once (sessions and the text encoder's cache are thread-safe).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "error.hpp"
#include "features.hpp"
#include "onnx_session.hpp"
#include "skeleton.hpp"
#include "text_encoder.hpp"

namespace ardy {

inline constexpr const char* kPackageFormat = "ardy-model-package";
// 2: the history's keys and values (history graph) and the goals' share of
// the input projections (goals graph) come once per window (1: the denoiser
// took the history tokens and the goals at every call).
inline constexpr int kPackageFormatVersion = 2;

// tokens.* of model.json (docs/model_contract.md section 1).
struct TokenSizes {
  size_t patch = 0;                                                 // P: frames per token
  size_t latent_dim = 0;                                            // L
  size_t token_dim = 0;                                             // D = 5 P + L
  size_t window = 0;                                                // C: window tokens
  size_t max_history = 0;                                           // H_max
  size_t max_future = 0;                                            // F_max
  size_t goal_dim = 0;                                              // P * M
  size_t root_token_dim() const { return token_dim - latent_dim; }  // 5 P
  size_t window_frames() const { return window * patch; }
};

// diffusion.* of model.json: the noise schedule the denoiser was trained with.
struct DiffusionSchedule {
  std::vector<double> alphas_cumprod;  // [N], t = N - 1 the noisiest
  size_t num_steps() const { return alphas_cumprod.size(); }
};

// denoiser.* of model.json: the transformers' sizes. The history graph's keys
// and values are [B, stages * layers, 2, heads, H, width / heads]; the bench
// counts FLOPs with them.
struct DenoiserSizes {
  bool two_stage = true;
  size_t width = 0;
  size_t layers = 0;
  size_t heads = 0;
  size_t ff_mult = 0;
  size_t window_goal_dim = 0;  // goal entries beside each window token: goal_dim ("full") or its body part ("body")
  // Every layer's step, text, window and future tokens also shifted, scaled and
  // gated from the step and text (inside denoiser.onnx; the graphs' inputs and
  // outputs are the same either way). Optional in model.json, false when absent.
  bool condition_modulation = false;
  size_t stages() const { return two_stage ? 2 : 1; }
  size_t head_dim() const { return width / heads; }
  size_t cached_layers() const { return stages() * layers; }
};

// sampling.* of model.json.
struct SamplingDefaults {
  size_t steps = 4;
  float w_text = 2.0f;
  float w_con = 2.0f;
  size_t decode_context_tokens = 4;
  double output_smoothing_frames = 0.0;  // motion_filter.hpp; optional in model.json (absent: off)
  bool interpolate_root = false;         // GoalSpec::interpolate_root; optional in model.json (absent: off)
  float path_guidance_scale = 1.0f;      // WindowInput::path_guidance_scale; optional (absent: 1), (0, 1]
  float text_only_guidance_scale = 1.0f;  // WindowInput::text_only_guidance_scale; optional (absent: 1), (0, 4]
};

// The range every reader of path_guidance_scale accepts: 0 would switch the
// goals' guidance off on dense paths, above 1 would push them harder than elsewhere.
inline bool path_guidance_scale_in_range(double scale) { return scale > 0.0 && scale <= 1.0; }

// The range every reader of text_only_guidance_scale accepts: 0 would switch
// the text off where nothing else steers; past 4 (w_text 8 at the default 2)
// the motion breaks up.
constexpr double kMaxTextOnlyGuidanceScale = 4.0;
inline bool text_only_guidance_scale_in_range(double scale) {
  return scale > 0.0 && scale <= kMaxTextOnlyGuidanceScale;
}

// The names and signature of one graph (graphs.<key> of model.json).
struct GraphSpec {
  std::string key;   // "history", "goals", "denoiser", "decoder", "encoder", "text_encoder"
  std::string file;  // e.g. "denoiser.onnx"
  std::vector<TensorInfo> inputs;
  std::vector<TensorInfo> outputs;
};

// text.* of model.json that the runtime uses.
struct TextSettings {
  std::string graph_file;  // text.graph
  std::string vocab_file;  // text.vocab
  size_t embedding_size = 0;
  WordPieceOptions tokenizer;  // max_tokens, casing, accents, CJK, specials, prefix
};

// Raw bytes of one package file, not owned.
struct ByteView {
  const void* data = nullptr;
  size_t size = 0;
};

// File name (as model.json names it, e.g. "denoiser.onnx") -> bytes.
using PackageFiles = std::map<std::string, std::string>;
using PackageFileViews = std::map<std::string, ByteView>;
// Returns the bytes of one package file (e.g. "denoiser.onnx"), or throws
// ardy::Error naming it; how an engine reads from its own file system.
using PackageFileReader = std::function<std::string(const std::string& file)>;

struct PackageOptions {
  SessionOptions session;  // intra-op threads of every graph
  // Cache size and prompt length limit of the text encoder (the graph's
  // input and output names come from model.json).
  TextEncoderOptions text;
  // Shared with other packages when set; otherwise the package makes one,
  // with one intra-op pool for all its graphs when shared_thread_pool (its
  // size and spinning from `session`; EnvironmentOptions). With spinning, a
  // 4-step window of the shipped model takes about 28 % less time on
  // 2 cores for about 0.03 more cores of CPU while a planner streams (bench/).
  std::shared_ptr<OnnxEnvironment> environment;
  bool shared_thread_pool = false;
};

class ModelPackage {
 public:
  static constexpr const char* kModelFile = "model.json";

  // Loads `folder`/model.json and the files it names. Errors name the path.
  static ModelPackage from_folder(const std::string& folder, const PackageOptions& options = {});
  // Loads from bytes: files["model.json"] and every file model.json names.
  // The bytes need not outlive the call. `name` names the package in errors.
  static ModelPackage from_memory(const PackageFiles& files, const std::string& name = "package",
                                  const PackageOptions& options = {});
  static ModelPackage from_memory(const PackageFileViews& files, const std::string& name = "package",
                                  const PackageOptions& options = {});
  // Loads model.json and then each file it names through `read` (only the
  // files the package needs are read). `name` names the package in errors.
  static ModelPackage from_reader(const PackageFileReader& read, const std::string& name,
                                  const PackageOptions& options = {});

  ModelPackage(ModelPackage&&) noexcept;
  ModelPackage& operator=(ModelPackage&&) noexcept;
  ModelPackage(const ModelPackage&) = delete;
  ModelPackage& operator=(const ModelPackage&) = delete;
  ~ModelPackage();

  const std::string& name() const;        // the folder, or the name given to from_memory
  const std::string& model_json() const;  // the text of model.json as loaded

  double fps() const;
  const FeatureLayout& layout() const;  // M = layout().feature_size
  const Skeleton& skeleton() const;
  const std::vector<std::string>& contact_joints() const;  // features.contact_joints
  const TokenSizes& tokens() const;
  const Normalization& feature_normalization() const;  // [M]
  const Normalization& latent_normalization() const;   // [L]
  const DiffusionSchedule& schedule() const;
  const SamplingDefaults& sampling_defaults() const;
  const DenoiserSizes& denoiser_sizes() const;
  const TextSettings& text_settings() const;
  size_t text_embedding_size() const;  // E: denoiser text_embedding width

  // The history's keys and values and the goals' share of the input
  // projections (both once per window), then the denoiser that takes them
  // (every step, every guidance row).
  const OnnxSession& history() const;
  const OnnxSession& goals() const;
  const OnnxSession& denoiser() const;
  const OnnxSession& decoder() const;
  const OnnxSession& encoder() const;
  const TextEncoder& text_encoder() const;
  const GraphSpec& graph_spec(const std::string& key) const;  // Error for an unknown key
  const std::shared_ptr<OnnxEnvironment>& environment() const;

 private:
  struct Impl;
  explicit ModelPackage(std::unique_ptr<Impl> impl);
  const Impl& impl() const;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ardy
