#include "onnx_session.hpp"

#include <onnxruntime_cxx_api.h>
#include <onnxruntime_session_options_config_keys.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <new>
#include <set>
#include <sstream>
#include <system_error>
#include <thread>

#include "generation_cpu.hpp"

namespace ardy {
namespace {

std::string in_quotes(const std::string& s) { return "'" + s + "'"; }

// The shared pool's threads are made here so their CPU time counts as
// generation (generation_cpu.hpp); ONNX Runtime joins them through the second.
OrtCustomThreadHandle create_pool_thread(void*, OrtThreadWorkerFn work, void* work_argument) {
  try {
    auto thread = std::make_unique<std::thread>([work, work_argument] {
      GenerationThreadScope counted;
      work(work_argument);
    });
    return reinterpret_cast<OrtCustomThreadHandle>(thread.release());
  } catch (const std::exception&) {
    return nullptr;  // ONNX Runtime reports the failed thread creation
  }
}

void join_pool_thread(OrtCustomThreadHandle handle) {
  std::unique_ptr<std::thread> thread(reinterpret_cast<std::thread*>(const_cast<OrtCustomHandleType*>(handle)));
  if (thread && thread->joinable()) thread->join();
}

// "[batch, 8]": the graph's view of a shape, symbolic names where it has them.
std::string format_graph_shape(const TensorInfo& info) {
  std::ostringstream out;
  out << '[';
  for (size_t i = 0; i < info.shape.size(); ++i) {
    if (i) out << ", ";
    if (info.shape[i] >= 0) {
      out << info.shape[i];
    } else {
      const std::string& sym = i < info.symbolic_dims.size() ? info.symbolic_dims[i] : std::string();
      out << (sym.empty() ? "?" : sym);
    }
  }
  out << ']';
  return out.str();
}

std::string format_shape(const std::vector<int64_t>& shape) {
  std::ostringstream out;
  out << '[';
  for (size_t i = 0; i < shape.size(); ++i) out << (i ? ", " : "") << shape[i];
  out << ']';
  return out.str();
}

const char* onnx_dtype_name(ONNXTensorElementDataType type) {
  switch (type) {
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT: return "float32";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_UINT8: return "uint8";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_INT8: return "int8";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_UINT16: return "uint16";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_INT16: return "int16";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_INT32: return "int32";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_INT64: return "int64";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_STRING: return "string";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_BOOL: return "bool";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT16: return "float16";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_DOUBLE: return "float64";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_UINT32: return "uint32";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_UINT64: return "uint64";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_COMPLEX64: return "complex64";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_COMPLEX128: return "complex128";
    case ONNX_TENSOR_ELEMENT_DATA_TYPE_BFLOAT16: return "bfloat16";
    default: return "unsupported";
  }
}

const char* onnx_kind_name(ONNXType type) {
  switch (type) {
    case ONNX_TYPE_SEQUENCE: return "sequence";
    case ONNX_TYPE_MAP: return "map";
    case ONNX_TYPE_OPAQUE: return "opaque";
    case ONNX_TYPE_SPARSETENSOR: return "sparse_tensor";
    case ONNX_TYPE_OPTIONAL: return "optional";
    default: return "unknown";
  }
}

TensorInfo describe(const std::string& name, const Ort::TypeInfo& type_info) {
  TensorInfo info;
  info.name = name;
  const ONNXType kind = type_info.GetONNXType();
  if (kind != ONNX_TYPE_TENSOR) {
    info.dtype = onnx_kind_name(kind);
    return info;
  }
  auto tensor_info = type_info.GetTensorTypeAndShapeInfo();
  info.dtype = onnx_dtype_name(tensor_info.GetElementType());
  info.shape = tensor_info.GetShape();
  const std::vector<const char*> symbolic = tensor_info.GetSymbolicDimensions();
  info.symbolic_dims.reserve(info.shape.size());
  for (size_t i = 0; i < info.shape.size(); ++i) {
    // ORT may report a name for a fixed axis too; only dynamic axes keep one.
    const bool named = i < symbolic.size() && symbolic[i] != nullptr && info.shape[i] < 0;
    info.symbolic_dims.emplace_back(named ? symbolic[i] : "");
  }
  return info;
}

std::string describe_load_failure(const std::string& name, const Ort::Exception& e) {
  std::string what;
  switch (e.GetOrtErrorCode()) {
    case ORT_NO_SUCHFILE: what = "file not found or not readable"; break;
    case ORT_INVALID_PROTOBUF: what = "not a valid ONNX model"; break;
    case ORT_INVALID_GRAPH: what = "not a valid ONNX graph"; break;
    case ORT_NOT_IMPLEMENTED:
      what = "uses an operator or type this ONNX Runtime (" + OnnxEnvironment::runtime_version() +
             ") does not support";
      break;
    default: what = "cannot load the ONNX model"; break;
  }
  return name + ": " + what + " (" + e.what() + ")";
}

// Product of the dims, or an Error when a dim is negative or the product
// overflows size_t (a hostile shape must not wrap around to a small count).
size_t checked_element_count(const std::string& where, const std::vector<int64_t>& shape) {
  size_t count = 1;
  for (int64_t dim : shape) {
    if (dim < 0) throw Error(where + ": negative dimension in shape " + format_shape(shape));
    const auto d = static_cast<uint64_t>(dim);
    if (d != 0 && count > std::numeric_limits<size_t>::max() / d) {
      throw Error(where + ": shape " + format_shape(shape) + " has too many elements");
    }
    count *= static_cast<size_t>(d);
  }
  return count;
}

}  // namespace

// ---------------------------------------------------------------------------

const char* element_type_name(ElementType type) {
  switch (type) {
    case ElementType::float32: return "float32";
    case ElementType::int64: return "int64";
  }
  return "unknown";
}

Tensor Tensor::float32(std::vector<int64_t> shape, std::vector<float> data) {
  Tensor t;
  t.shape = std::move(shape);
  t.data = std::move(data);
  t.dtype = ElementType::float32;
  return t;
}

Tensor Tensor::int64(std::vector<int64_t> shape, std::vector<int64_t> data) {
  Tensor t;
  t.shape = std::move(shape);
  t.int64_data = std::move(data);
  t.dtype = ElementType::int64;
  return t;
}

size_t Tensor::stored_count() const {
  return dtype == ElementType::int64 ? int64_data.size() : data.size();
}

int effective_intra_op_threads(int requested) {
  if (requested > 0) return requested;
  const unsigned hardware = std::thread::hardware_concurrency();  // 0 when unknown
  return hardware > 1 ? static_cast<int>(hardware - 1) : 1;
}

// ---------------------------------------------------------------------------

struct OnnxEnvironment::Impl {
  Ort::Env env;
  bool shared_pool = false;
};

namespace {

// ONNX Runtime's release builds for Linux carry Microsoft's 1DS telemetry: a
// background thread started with the first environment resolves
// mobile.events.data.microsoft.com and posts events some seconds later,
// whatever DisableTelemetryEvents says (seen under strace; the fuzzer's leak
// check caught that thread's allocations). A game's runtime makes no network
// calls: ORT_DISABLE_TELEMETRY=1 before the first environment turns it off.
// A value the host process set itself is left alone.
void disable_onnx_telemetry() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (std::getenv(kOrtTelemetryVariable) != nullptr) return;
#ifdef _WIN32
    _putenv_s(kOrtTelemetryVariable, "1");
#else
    setenv(kOrtTelemetryVariable, "1", 0);
#endif
  });
}

}  // namespace

OnnxEnvironment::OnnxEnvironment(const EnvironmentOptions& options) {
  disable_onnx_telemetry();
  // The C++ header resolves the API table at static-init time; a runtime
  // older than the headers yields null there and every call would crash.
  if (Ort::Global<void>::api_ == nullptr) {
    throw Error("ONNX Runtime " + runtime_version() + " is older than the headers this library was built with (C API " +
                std::to_string(ORT_API_VERSION) + " needed): install a newer libonnxruntime");
  }
  if (options.shared_pool_threads < 0) {
    throw Error("ONNX Runtime: shared_pool_threads must be 0 (all cores but one) or positive, got " +
                std::to_string(options.shared_pool_threads));
  }
  try {
    if (options.shared_pool) {
      Ort::ThreadingOptions threading;
      threading.SetGlobalIntraOpNumThreads(effective_intra_op_threads(options.shared_pool_threads));
      threading.SetGlobalInterOpNumThreads(1);
      threading.SetGlobalSpinControl(options.allow_spinning ? 1 : 0);
      threading.SetGlobalCustomCreateThreadFn(create_pool_thread);
      threading.SetGlobalCustomJoinThreadFn(join_pool_thread);
      impl_ = std::make_unique<Impl>(Impl{Ort::Env(threading, ORT_LOGGING_LEVEL_WARNING, "ardy"), true});
    } else {
      impl_ = std::make_unique<Impl>(Impl{Ort::Env(ORT_LOGGING_LEVEL_WARNING, "ardy"), false});
    }
    impl_->env.DisableTelemetryEvents();  // the documented switch; see disable_onnx_telemetry
  } catch (const Ort::Exception& e) {
    throw Error(std::string("ONNX Runtime: cannot create the environment (") + e.what() + ")");
  }
}

OnnxEnvironment::~OnnxEnvironment() = default;

std::shared_ptr<OnnxEnvironment> OnnxEnvironment::create(const EnvironmentOptions& options) {
  return std::make_shared<OnnxEnvironment>(options);
}

bool OnnxEnvironment::shared_pool() const { return impl_ && impl_->shared_pool; }

std::string OnnxEnvironment::runtime_version() {
  const char* version = OrtGetApiBase()->GetVersionString();
  return version ? version : "(unknown version)";
}

// ---------------------------------------------------------------------------

struct OnnxSession::Impl {
  // Declared first so it is destroyed last: the session must die before the
  // environment it was created in.
  std::shared_ptr<OnnxEnvironment> env;
  std::string name;
  // Ort::Session::Run is thread-safe but declared non-const in the C++
  // wrapper; mutable lets OnnxSession::run stay const.
  mutable Ort::Session session{nullptr};
  std::vector<TensorInfo> inputs;
  std::vector<TensorInfo> outputs;
  Ort::MemoryInfo cpu_memory{nullptr};

  static const TensorInfo* find(const std::vector<TensorInfo>& list, const std::string& wanted) {
    for (const TensorInfo& info : list) {
      if (info.name == wanted) return &info;
    }
    return nullptr;
  }

  // Creates the Ort::Session with make_session(env, options) and reads the
  // graph's signature once, so later calls never go back to ORT for it.
  template <typename MakeSession>
  static std::unique_ptr<Impl> load(std::shared_ptr<OnnxEnvironment> env, const std::string& name,
                                    const SessionOptions& options, MakeSession&& make_session);
};

namespace {

Ort::SessionOptions make_ort_options(const std::string& name, const SessionOptions& options) {
  if (options.intra_op_threads < 0) {
    throw Error(name + ": SessionOptions.intra_op_threads must be 0 (all cores but one) or positive, got " +
                std::to_string(options.intra_op_threads));
  }
  Ort::SessionOptions ort_options;
  ort_options.SetIntraOpNumThreads(effective_intra_op_threads(options.intra_op_threads));
  // One graph call at a time per session: parallelism comes from intra-op
  // threads, and the planner owns any concurrency above that.
  ort_options.SetInterOpNumThreads(1);
  ort_options.SetExecutionMode(ORT_SEQUENTIAL);
  ort_options.SetGraphOptimizationLevel(GraphOptimizationLevel::ORT_ENABLE_ALL);
  ort_options.AddConfigEntry(kOrtSessionOptionsConfigAllowIntraOpSpinning, options.allow_spinning ? "1" : "0");
  ort_options.AddConfigEntry(kOrtSessionOptionsConfigAllowInterOpSpinning, options.allow_spinning ? "1" : "0");
  return ort_options;
}

}  // namespace

template <typename MakeSession>
std::unique_ptr<OnnxSession::Impl> OnnxSession::Impl::load(std::shared_ptr<OnnxEnvironment> env,
                                                           const std::string& name, const SessionOptions& options,
                                                           MakeSession&& make_session) {
  if (!env) throw Error(name + ": no ONNX Runtime environment given (OnnxEnvironment::create() makes one)");
  auto impl = std::make_unique<OnnxSession::Impl>();
  impl->env = std::move(env);
  impl->name = name;
  try {
    Ort::SessionOptions ort_options = make_ort_options(name, options);
    if (impl->env->shared_pool()) ort_options.DisablePerSessionThreads();
    impl->session = make_session(impl->env->impl_->env, ort_options);
  } catch (const Ort::Exception& e) {
    if (impl->env->shared_pool() && std::string(e.what()).find("GlobalThreadPools") != std::string::npos) {
      throw Error(name + ": cannot use a shared thread pool: ONNX Runtime keeps one environment per process, and "
                         "the one alive was made without a shared thread pool (load the model that asks for one "
                         "first, or load this one without it)");
    }
    throw Error(describe_load_failure(name, e));
  } catch (const std::bad_alloc&) {
    throw Error(name + ": out of memory while loading the ONNX model");
  }
  try {
    Ort::AllocatorWithDefaultOptions allocator;
    const size_t input_count = impl->session.GetInputCount();
    for (size_t i = 0; i < input_count; ++i) {
      const std::string input_name = impl->session.GetInputNameAllocated(i, allocator).get();
      impl->inputs.push_back(describe(input_name, impl->session.GetInputTypeInfo(i)));
    }
    const size_t output_count = impl->session.GetOutputCount();
    for (size_t i = 0; i < output_count; ++i) {
      const std::string output_name = impl->session.GetOutputNameAllocated(i, allocator).get();
      impl->outputs.push_back(describe(output_name, impl->session.GetOutputTypeInfo(i)));
    }
    impl->cpu_memory = Ort::MemoryInfo::CreateCpu(OrtArenaAllocator, OrtMemTypeDefault);
  } catch (const Ort::Exception& e) {
    throw Error(name + ": cannot read the model's inputs and outputs (" + e.what() + ")");
  }
  return impl;
}

OnnxSession OnnxSession::from_file(std::shared_ptr<OnnxEnvironment> env, const std::string& path,
                                   const SessionOptions& options) {
  // Checked here because ORT's own message for a missing file is less direct.
  std::error_code ec;
  const std::filesystem::path fs_path(path);
  if (!std::filesystem::exists(fs_path, ec)) {
    throw Error(path + ": file not found (expected an ONNX model)");
  }
  if (!std::filesystem::is_regular_file(fs_path, ec)) {
    throw Error(path + ": not a regular file (expected an ONNX model)");
  }
  if (std::filesystem::file_size(fs_path, ec) == 0 && !ec) {
    throw Error(path + ": empty file (expected an ONNX model)");
  }
  // Loading by path (not by bytes) lets ORT find external weight files next to the model.
  return OnnxSession(Impl::load(std::move(env), path, options,
                                [&](const Ort::Env& ort_env, const Ort::SessionOptions& ort_options) {
                                  return Ort::Session(ort_env, fs_path.c_str(), ort_options);
                                }));
}

OnnxSession OnnxSession::from_memory(std::shared_ptr<OnnxEnvironment> env, const void* data, size_t size,
                                     const std::string& name, const SessionOptions& options) {
  if (data == nullptr || size == 0) {
    throw Error(name + ": empty buffer (expected the bytes of an ONNX model)");
  }
  return OnnxSession(Impl::load(std::move(env), name, options,
                                [&](const Ort::Env& ort_env, const Ort::SessionOptions& ort_options) {
                                  return Ort::Session(ort_env, data, size, ort_options);
                                }));
}

OnnxSession::OnnxSession(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
OnnxSession::OnnxSession(OnnxSession&&) noexcept = default;
OnnxSession& OnnxSession::operator=(OnnxSession&&) noexcept = default;
OnnxSession::~OnnxSession() = default;

const OnnxSession::Impl& OnnxSession::impl() const {
  if (!impl_) throw Error("OnnxSession: used after being moved from");
  return *impl_;
}

const std::string& OnnxSession::name() const { return impl().name; }
const std::vector<TensorInfo>& OnnxSession::inputs() const { return impl().inputs; }
const std::vector<TensorInfo>& OnnxSession::outputs() const { return impl().outputs; }
const TensorInfo* OnnxSession::find_input(const std::string& name) const { return impl().find(impl().inputs, name); }
const TensorInfo* OnnxSession::find_output(const std::string& name) const {
  return impl().find(impl().outputs, name);
}

std::vector<Tensor> OnnxSession::run(const std::vector<std::pair<std::string, Tensor>>& inputs,
                                     const std::vector<std::string>& output_names) const {
  check_inputs(inputs, nullptr);
  return execute(inputs, check_outputs(output_names));
}

void OnnxSession::check_inputs(const std::vector<std::pair<std::string, Tensor>>& inputs,
                               const std::vector<bool>* values_of) const {
  const Impl& s = impl();
  const std::string& session_name = s.name;

  // --- inputs: names, dtypes, shapes, element counts, finiteness ---------
  std::set<std::string> given;
  std::map<std::string, std::pair<int64_t, std::string>> symbolic_sizes;  // axis name -> (size, input)
  for (size_t input = 0; input < inputs.size(); ++input) {
    const auto& [input_name, tensor] = inputs[input];
    const std::string where = session_name + ": input " + in_quotes(input_name);
    const TensorInfo* info = s.find(s.inputs, input_name);
    if (info == nullptr) {
      std::string known;
      for (const TensorInfo& i : s.inputs) known += (known.empty() ? "" : ", ") + in_quotes(i.name);
      throw Error(session_name + ": unknown input " + in_quotes(input_name) + " (the graph's inputs are " + known +
                  ")");
    }
    if (!given.insert(input_name).second) throw Error(where + " given more than once");
    if (info->dtype != element_type_name(tensor.dtype)) {
      throw Error(where + ": expected dtype " + info->dtype + ", got " + element_type_name(tensor.dtype));
    }
    if (tensor.shape.size() != info->shape.size()) {
      throw Error(where + ": expected rank " + std::to_string(info->shape.size()) + " " + format_graph_shape(*info) +
                  ", got shape " + format_shape(tensor.shape));
    }
    const size_t count = checked_element_count(where, tensor.shape);
    for (size_t axis = 0; axis < tensor.shape.size(); ++axis) {
      const int64_t expected = info->shape[axis];
      if (expected >= 0 && tensor.shape[axis] != expected) {
        throw Error(where + ": expected shape " + format_graph_shape(*info) + ", got " + format_shape(tensor.shape) +
                    " (axis " + std::to_string(axis) + " must be " + std::to_string(expected) + ")");
      }
      const std::string& symbol = info->symbolic_dims[axis];
      if (expected < 0 && !symbol.empty()) {
        const auto [it, inserted] = symbolic_sizes.emplace(symbol, std::make_pair(tensor.shape[axis], input_name));
        if (!inserted && it->second.first != tensor.shape[axis]) {
          throw Error(where + ": axis " + std::to_string(axis) + " (" + in_quotes(symbol) + ") is " +
                      std::to_string(tensor.shape[axis]) + " but input " + in_quotes(it->second.second) + " has " +
                      in_quotes(symbol) + " = " + std::to_string(it->second.first));
        }
      }
    }
    if (tensor.stored_count() != count) {
      throw Error(where + ": shape " + format_shape(tensor.shape) + " needs " + std::to_string(count) +
                  " elements, got " + std::to_string(tensor.stored_count()));
    }
    if (tensor.dtype == ElementType::float32 && (values_of == nullptr || (*values_of)[input])) {
      for (size_t i = 0; i < tensor.data.size(); ++i) {
        if (!std::isfinite(tensor.data[i])) {
          throw Error(where + ": element " + std::to_string(i) + " is " +
                      (std::isnan(tensor.data[i]) ? "NaN" : "infinite") + " (inputs must be finite)");
        }
      }
    }
  }
  for (const TensorInfo& info : s.inputs) {
    if (!given.count(info.name)) {
      throw Error(session_name + ": missing input " + in_quotes(info.name) + " " + format_graph_shape(info) + " " +
                  info.dtype);
    }
  }
}

std::vector<std::string> OnnxSession::check_outputs(const std::vector<std::string>& output_names) const {
  const Impl& s = impl();
  const std::string& session_name = s.name;
  std::vector<std::string> wanted = output_names;
  if (wanted.empty()) {
    for (const TensorInfo& info : s.outputs) wanted.push_back(info.name);
  }
  std::set<std::string> wanted_set;
  for (const std::string& output_name : wanted) {
    const TensorInfo* info = s.find(s.outputs, output_name);
    if (info == nullptr) {
      std::string known;
      for (const TensorInfo& i : s.outputs) known += (known.empty() ? "" : ", ") + in_quotes(i.name);
      throw Error(session_name + ": unknown output " + in_quotes(output_name) + " (the graph's outputs are " + known +
                  ")");
    }
    if (!wanted_set.insert(output_name).second) {
      throw Error(session_name + ": output " + in_quotes(output_name) + " requested more than once");
    }
    if (info->dtype != "float32" && info->dtype != "int64") {
      throw Error(session_name + ": output " + in_quotes(output_name) + " has dtype " + info->dtype +
                  "; only float32 and int64 outputs are supported");
    }
  }
  return wanted;
}

std::vector<Tensor> OnnxSession::execute(const std::vector<std::pair<std::string, Tensor>>& inputs,
                                         const std::vector<std::string>& wanted) const {
  const Impl& s = impl();
  const std::string& session_name = s.name;
  try {
    std::vector<const char*> input_names;
    std::vector<Ort::Value> input_values;
    input_names.reserve(inputs.size());
    input_values.reserve(inputs.size());
    for (const auto& [input_name, tensor] : inputs) {
      input_names.push_back(input_name.c_str());
      // ORT only reads input tensors, so wrapping the caller's const data
      // without a copy is safe.
      if (tensor.dtype == ElementType::float32) {
        input_values.push_back(Ort::Value::CreateTensor<float>(s.cpu_memory, const_cast<float*>(tensor.data.data()),
                                                               tensor.data.size(), tensor.shape.data(),
                                                               tensor.shape.size()));
      } else {
        input_values.push_back(Ort::Value::CreateTensor<int64_t>(
            s.cpu_memory, const_cast<int64_t*>(tensor.int64_data.data()), tensor.int64_data.size(),
            tensor.shape.data(), tensor.shape.size()));
      }
    }
    std::vector<const char*> output_c_names;
    output_c_names.reserve(wanted.size());
    for (const std::string& output_name : wanted) output_c_names.push_back(output_name.c_str());

    std::vector<Ort::Value> results =
        s.session.Run(Ort::RunOptions{nullptr}, input_names.data(), input_values.data(), input_values.size(),
                      output_c_names.data(), output_c_names.size());

    std::vector<Tensor> outputs;
    outputs.reserve(results.size());
    for (size_t i = 0; i < results.size(); ++i) {
      const Ort::Value& value = results[i];
      if (!value.IsTensor()) {
        throw Error(session_name + ": output " + in_quotes(wanted[i]) + " is not a tensor");
      }
      auto shape_info = value.GetTensorTypeAndShapeInfo();
      const ONNXTensorElementDataType type = shape_info.GetElementType();
      const size_t count = shape_info.GetElementCount();
      if (type == ONNX_TENSOR_ELEMENT_DATA_TYPE_FLOAT) {
        const float* begin = value.GetTensorData<float>();
        outputs.push_back(Tensor::float32(shape_info.GetShape(), std::vector<float>(begin, begin + count)));
      } else if (type == ONNX_TENSOR_ELEMENT_DATA_TYPE_INT64) {
        const int64_t* begin = value.GetTensorData<int64_t>();
        outputs.push_back(Tensor::int64(shape_info.GetShape(), std::vector<int64_t>(begin, begin + count)));
      } else {
        throw Error(session_name + ": output " + in_quotes(wanted[i]) + " has dtype " + onnx_dtype_name(type) +
                    "; only float32 and int64 outputs are supported");
      }
    }
    return outputs;
  } catch (const Ort::Exception& e) {
    throw Error(session_name + ": inference failed (" + e.what() + ")");
  } catch (const std::bad_alloc&) {
    throw Error(session_name + ": out of memory during inference");
  }
}

// --- RepeatedRun ---------------------------------------------------------------

RepeatedRun::RepeatedRun(const OnnxSession& session, std::vector<std::pair<std::string, Tensor>> inputs,
                         std::vector<std::string> output_names)
    : session_(&session), inputs_(std::move(inputs)), changed_(inputs_.size(), false) {
  session.check_inputs(inputs_, nullptr);
  outputs_ = session.check_outputs(output_names);
}

size_t RepeatedRun::index_of(const std::string& input, ElementType dtype) const {
  for (size_t i = 0; i < inputs_.size(); ++i) {
    if (inputs_[i].first != input) continue;
    if (inputs_[i].second.dtype != dtype) {
      throw Error(session_->name() + ": input " + in_quotes(input) + " holds " +
                  element_type_name(inputs_[i].second.dtype) + ", not " + element_type_name(dtype));
    }
    return i;
  }
  throw Error(session_->name() + ": this run has no input " + in_quotes(input));
}

std::vector<float>& RepeatedRun::values(const std::string& input) {
  const size_t i = index_of(input, ElementType::float32);
  changed_[i] = true;
  return inputs_[i].second.data;
}

std::vector<int64_t>& RepeatedRun::int64_values(const std::string& input) {
  const size_t i = index_of(input, ElementType::int64);
  changed_[i] = true;
  return inputs_[i].second.int64_data;
}

std::vector<Tensor> RepeatedRun::run() {
  // Shapes are fixed, but a caller may have resized a vector: check_inputs
  // compares every element count again (cheap) and scans the changed values.
  session_->check_inputs(inputs_, &changed_);
  std::fill(changed_.begin(), changed_.end(), false);
  return session_->execute(inputs_, outputs_);
}

}  // namespace ardy
