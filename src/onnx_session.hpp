#pragma once

// RAII wrapper over ONNX Runtime: one shared environment, sessions loaded from
// a file or a memory buffer, graph signatures as plain structs, and a run()
// that validates every input against the graph before ONNX Runtime sees it.
// No ONNX Runtime type appears here, so engine bindings that include this
// header do not pull in the (large) ORT C++ headers.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "error.hpp"  // ardy::Error, e.g. "denoiser.onnx: not a valid ONNX model (...)"

namespace ardy {

// How the sessions of an environment get their threads.
struct EnvironmentOptions {
  // One intra-op pool for every session of the environment (its size:
  // shared_pool_threads, 0 = all cores but one), instead of a pool per session
  // (SessionOptions thread settings are then ignored). ONNX Runtime keeps one
  // environment per process, so the first one alive decides for all.
  bool shared_pool = false;
  int shared_pool_threads = 0;
  bool allow_spinning = false;  // idle threads of the shared pool spin
};

// The environment variable that turns ONNX Runtime's telemetry off; the first
// OnnxEnvironment sets it to 1 unless the process already has it.
constexpr const char* kOrtTelemetryVariable = "ORT_DISABLE_TELEMETRY";

// One ONNX Runtime environment (logging level warning, log id "ardy", no
// telemetry), shared by every session through std::shared_ptr so it outlives
// all of them.
class OnnxEnvironment {
 public:
  // Throws Error when the loaded libonnxruntime cannot serve the API version
  // the headers were compiled against (an older runtime than the headers).
  explicit OnnxEnvironment(const EnvironmentOptions& options = {});
  ~OnnxEnvironment();
  OnnxEnvironment(const OnnxEnvironment&) = delete;
  OnnxEnvironment& operator=(const OnnxEnvironment&) = delete;
  OnnxEnvironment(OnnxEnvironment&&) = delete;
  OnnxEnvironment& operator=(OnnxEnvironment&&) = delete;

  static std::shared_ptr<OnnxEnvironment> create(const EnvironmentOptions& options = {});
  bool shared_pool() const;

  // Version of the loaded libonnxruntime, e.g. "1.31.1".
  static std::string runtime_version();

 private:
  friend class OnnxSession;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct SessionOptions {
  int intra_op_threads = 0;  // 0 = all cores but one, at least one
  // Idle ORT worker threads spin by default; off, so a waiting pool does not
  // steal CPU from the game's own threads between inference calls.
  bool allow_spinning = false;
};

// The thread count SessionOptions::intra_op_threads resolves to (requested
// when > 0, else hardware threads minus one, at least one).
int effective_intra_op_threads(int requested);

// Signature of one graph input or output.
struct TensorInfo {
  std::string name;
  std::string dtype;                       // "float32", "int64", ... ("sequence", "map" for non-tensors)
  std::vector<int64_t> shape;              // -1 for symbolic or unknown axes
  std::vector<std::string> symbolic_dims;  // one per axis: its symbolic name, "" for fixed (or unnamed) axes
};

enum class ElementType { float32, int64 };

const char* element_type_name(ElementType type);  // "float32", "int64"

// A dense row-major tensor. Only the vector matching `dtype` holds elements.
struct Tensor {
  std::vector<int64_t> shape;
  std::vector<float> data;          // elements when dtype == float32
  std::vector<int64_t> int64_data;  // elements when dtype == int64
  ElementType dtype = ElementType::float32;

  static Tensor float32(std::vector<int64_t> shape, std::vector<float> data);
  static Tensor int64(std::vector<int64_t> shape, std::vector<int64_t> data);

  // Number of elements stored in the vector that matches dtype.
  size_t stored_count() const;
};

class OnnxSession {
 public:
  // Loads a model file. `path` names the session in every error message.
  static OnnxSession from_file(std::shared_ptr<OnnxEnvironment> env, const std::string& path,
                               const SessionOptions& options = {});
  // Loads a model from bytes (e.g. read by an engine from a packed archive).
  // The bytes are parsed during the call and need not outlive it. `name`
  // names the session in every error message.
  static OnnxSession from_memory(std::shared_ptr<OnnxEnvironment> env, const void* data, size_t size,
                                 const std::string& name, const SessionOptions& options = {});

  OnnxSession(OnnxSession&&) noexcept;
  OnnxSession& operator=(OnnxSession&&) noexcept;
  OnnxSession(const OnnxSession&) = delete;
  OnnxSession& operator=(const OnnxSession&) = delete;
  ~OnnxSession();

  // Every accessor and run() throws Error on a moved-from session.
  const std::string& name() const;
  const std::vector<TensorInfo>& inputs() const;
  const std::vector<TensorInfo>& outputs() const;
  const TensorInfo* find_input(const std::string& name) const;   // nullptr when absent
  const TensorInfo* find_output(const std::string& name) const;  // nullptr when absent

  // Runs the graph. Every graph input must be given exactly once, with the
  // graph's dtype, rank and fixed dims, a consistent size for each symbolic
  // axis name across inputs, as many elements as its shape says, and finite
  // values. Returns the requested outputs in the order asked (all outputs in
  // graph order when output_names is empty). Any failure throws Error naming
  // the session. Safe to call from several threads at once.
  std::vector<Tensor> run(const std::vector<std::pair<std::string, Tensor>>& inputs,
                          const std::vector<std::string>& output_names) const;

 private:
  friend class RepeatedRun;
  // The checks of run(): every input's name, dtype and shape, and the values
  // of those in `values_of` (all when null) finite. Throws Error.
  void check_inputs(const std::vector<std::pair<std::string, Tensor>>& inputs,
                    const std::vector<bool>* values_of) const;
  // Output names -> the list to fetch (all when empty). Throws Error.
  std::vector<std::string> check_outputs(const std::vector<std::string>& output_names) const;
  std::vector<Tensor> execute(const std::vector<std::pair<std::string, Tensor>>& inputs,
                              const std::vector<std::string>& outputs) const;

  struct Impl;
  explicit OnnxSession(std::unique_ptr<Impl> impl);
  const Impl& impl() const;
  std::unique_ptr<Impl> impl_;
};

// One session run many times with inputs of fixed shapes, most of which stay
// the same between runs (a DDIM loop changes only x_t and the step). Every
// input is checked once when made; values() gives write access to one input
// and has run() check it again, so unchanged inputs are not scanned at every
// call. The session must outlive this object.
class RepeatedRun {
 public:
  RepeatedRun(const OnnxSession& session, std::vector<std::pair<std::string, Tensor>> inputs,
              std::vector<std::string> output_names);
  // The elements of one input (float32 or int64, its shape fixed); Error for
  // an unknown name or the other dtype.
  std::vector<float>& values(const std::string& input);
  std::vector<int64_t>& int64_values(const std::string& input);
  std::vector<Tensor> run();

 private:
  size_t index_of(const std::string& input, ElementType dtype) const;
  const OnnxSession* session_;
  std::vector<std::pair<std::string, Tensor>> inputs_;
  std::vector<std::string> outputs_;
  std::vector<bool> changed_;
};

}  // namespace ardy
