#include "package.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <utility>

#include <nlohmann/json.hpp>

#include "io.hpp"
#include "motion_filter.hpp"
#include "json_text.hpp"
#include "onnx_external_data.hpp"

namespace ardy {
namespace {

using json = nlohmann::json;

constexpr size_t kMaxModelJsonBytes = size_t{64} << 20;
constexpr size_t kMaxVocabBytes = size_t{64} << 20;
constexpr size_t kMaxGraphBytes = size_t{2} << 30;
// Sizes beyond these are not a model this runtime can run, and keep the
// products below (goal_dim, token_dim) far from overflow.
constexpr int64_t kMaxSize = int64_t{1} << 24;

std::string in_quotes(const std::string& s) { return "'" + s + "'"; }

// Refuses a graph whose tensors keep their data in external files that could
// lie outside the package (onnx_external_data.hpp says why). From a folder,
// a location must be a plain relative path inside it; bytes given in memory
// or through a reader have no folder, and ONNX Runtime would resolve the
// location against the process's working folder, so none is allowed.
// Returns the locations (for the folder's symbolic-link check).
std::vector<std::string> check_external_data(const void* data, size_t size, const std::string& where,
                                             bool in_folder) {
  std::vector<std::string> locations;
  for (const onnx_scan::ExternalTensor& t : onnx_scan::external_tensors(data, size, where)) {
    const std::string tensor = "tensor " + in_quotes(t.tensor) + " keeps its data in external file " +
                               in_quotes(t.location);
    if (!in_folder) {
      throw Error(where + ": " + tensor +
                  "; a package loaded from memory must embed every tensor (external data is refused)");
    }
    const std::string reason = onnx_scan::unsafe_path_reason(t.location);
    if (!reason.empty()) {
      throw Error(where + ": " + tensor + ", whose location " + reason +
                  " (expected a relative path inside the package folder)");
    }
    locations.push_back(t.location);
  }
  return locations;
}


// --- where the bytes come from ------------------------------------------------

class FileSource {
 public:
  virtual ~FileSource() = default;
  // How errors name a file of the package.
  virtual std::string where(const std::string& file) const = 0;
  virtual std::string read(const std::string& file, const std::string& expected, size_t max_bytes) const = 0;
  virtual OnnxSession session(std::shared_ptr<OnnxEnvironment> env, const std::string& file,
                              const SessionOptions& options) const = 0;
};

class FolderSource final : public FileSource {
 public:
  explicit FolderSource(std::string folder) : folder_(std::move(folder)) {}

  std::string where(const std::string& file) const override { return (std::filesystem::path(folder_) / file).string(); }
  std::string read(const std::string& file, const std::string& expected, size_t max_bytes) const override {
    check_inside(file, file);
    return read_file(where(file), expected, max_bytes);
  }
  OnnxSession session(std::shared_ptr<OnnxEnvironment> env, const std::string& file,
                      const SessionOptions& options) const override {
    check_inside(file, file);
    // Scanned first: every external-data location must stay in the folder.
    const std::string bytes = read_file(where(file), "an ONNX model", kMaxGraphBytes);
    const std::filesystem::path graph_dir = std::filesystem::path(file).parent_path();
    for (const std::string& location : check_external_data(bytes.data(), bytes.size(), where(file), true)) {
      check_inside((graph_dir / location).generic_string(), file);
    }
    // By path, so ORT finds external weight files next to the graph.
    return OnnxSession::from_file(std::move(env), where(file), options);
  }

 private:
  // The names are plain relative paths (check_file_name), but a symbolic
  // link inside the folder could still lead out of it: what `relative`
  // resolves to must lie inside the folder. A file that does not exist is
  // left to the read that follows (it names it).
  void check_inside(const std::string& relative, const std::string& named_by) const {
    std::error_code ec;
    const std::filesystem::path root = std::filesystem::weakly_canonical(folder_, ec);
    if (ec) return;
    const std::filesystem::path target = std::filesystem::weakly_canonical(root / relative, ec);
    if (ec) return;
    const std::filesystem::path inside = target.lexically_relative(root);
    if (inside.empty() || *inside.begin() == "..") {
      throw Error(where(named_by) + ": " + in_quotes(relative) + " resolves to " + target.string() +
                  ", outside the package folder (a symbolic link?)");
    }
  }

  std::string folder_;
};

class MemorySource final : public FileSource {
 public:
  MemorySource(const PackageFileViews& files, std::string name) : files_(files), name_(std::move(name)) {}

  std::string where(const std::string& file) const override { return name_ + "/" + file; }

  std::string read(const std::string& file, const std::string& expected, size_t max_bytes) const override {
    const ByteView bytes = find(file, expected);
    if (bytes.size > max_bytes) {
      throw Error(where(file) + ": " + std::to_string(bytes.size) + " bytes, larger than the " +
                  std::to_string(max_bytes) + " bytes allowed for " + expected);
    }
    const char* begin = static_cast<const char*>(bytes.data);
    return bytes.size ? std::string(begin, begin + bytes.size) : std::string();
  }

  OnnxSession session(std::shared_ptr<OnnxEnvironment> env, const std::string& file,
                      const SessionOptions& options) const override {
    const ByteView bytes = find(file, "an ONNX model");
    if (bytes.size > kMaxGraphBytes) {
      throw Error(where(file) + ": " + std::to_string(bytes.size) + " bytes, larger than the " +
                  std::to_string(kMaxGraphBytes) + " bytes allowed for an ONNX model");
    }
    check_external_data(bytes.data, bytes.size, where(file), false);
    return OnnxSession::from_memory(std::move(env), bytes.data, bytes.size, where(file), options);
  }

 private:
  ByteView find(const std::string& file, const std::string& expected) const {
    const auto it = files_.find(file);
    if (it == files_.end()) {
      std::string given;
      for (const auto& entry : files_) given += (given.empty() ? "" : ", ") + in_quotes(entry.first);
      throw Error(where(file) + ": file not given (expected " + expected + "; the files given are " +
                  (given.empty() ? std::string("none") : given) + ")");
    }
    if (it->second.data == nullptr && it->second.size != 0) {
      throw Error(where(file) + ": null data pointer with a size of " + std::to_string(it->second.size));
    }
    return it->second;
  }

  const PackageFileViews& files_;
  std::string name_;
};

// --- model.json fields ----------------------------------------------------------

class Manifest {
 public:
  Manifest(const json& root, std::string file) : root_(root), file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw Error(file_ + ": " + path + " " + what);
  }
  const std::string& file() const { return file_; }

  // The value at a dotted path ("tokens.patch"); Error naming the path when
  // a part is missing or a parent is not an object.
  const json& at(const std::string& path) const {
    const json* node = &root_;
    std::string prefix;
    size_t begin = 0;
    for (;;) {
      const size_t dot = std::min(path.find('.', begin), path.size());
      const std::string key = path.substr(begin, dot - begin);
      if (!node->is_object()) {
        throw Error(file_ + ": " + (prefix.empty() ? std::string("the top level") : prefix) +
                    " must be an object, found " + describe_json(*node));
      }
      prefix += (prefix.empty() ? "" : ".") + key;
      const auto it = node->find(key);
      if (it == node->end()) throw Error(file_ + ": missing field " + prefix);
      node = &*it;
      if (dot == path.size()) return *node;
      begin = dot + 1;
    }
  }
  bool has(const std::string& path) const {
    try {
      at(path);
      return true;
    } catch (const Error&) {
      return false;
    }
  }

  int64_t integer(const json& value, const std::string& path, int64_t min, int64_t max = kMaxSize) const {
    if (!value.is_number_integer()) fail(path, "must be an integer, found " + describe_json(value));
    const bool huge = value.is_number_unsigned() && value.get<uint64_t>() > uint64_t(std::numeric_limits<int64_t>::max());
    const int64_t v = huge ? max : value.get<int64_t>();
    if (huge || v < min || v > max) {
      fail(path, "is " + describe_json(value) + ", expected " + std::to_string(min) + ".." + std::to_string(max));
    }
    return v;
  }
  size_t size(const std::string& path, int64_t min = 1, int64_t max = kMaxSize) const {
    return static_cast<size_t>(integer(at(path), path, min, max));
  }
  double number(const json& value, const std::string& path) const {
    if (!value.is_number()) fail(path, "must be a number, found " + describe_json(value));
    const double v = value.get<double>();
    if (!std::isfinite(v)) fail(path, "must be finite, found " + describe_json(value));
    return v;
  }
  double number(const std::string& path) const { return number(at(path), path); }
  bool boolean(const std::string& path) const {
    const json& value = at(path);
    if (!value.is_boolean()) fail(path, "must be true or false, found " + describe_json(value));
    return value.get<bool>();
  }
  std::string string(const json& value, const std::string& path) const {
    if (!value.is_string()) fail(path, "must be a string, found " + describe_json(value));
    return value.get<std::string>();
  }
  std::string string(const std::string& path) const { return string(at(path), path); }
  const json& array(const std::string& path, size_t expected, const std::string& why) const {
    const json& value = at(path);
    if (!value.is_array()) fail(path, "must be an array, found " + describe_json(value));
    if (value.size() != expected) {
      fail(path,
           "has " + std::to_string(value.size()) + " entries, expected " + std::to_string(expected) + " (" + why + ")");
    }
    return value;
  }
  std::vector<float> floats(const std::string& path, size_t expected, const std::string& why) const {
    const json& value = array(path, expected, why);
    std::vector<float> out;
    out.reserve(value.size());
    for (size_t i = 0; i < value.size(); ++i) {
      const double v = number(value[i], path + "[" + std::to_string(i) + "]");
      if (std::fabs(v) > double(std::numeric_limits<float>::max())) {
        fail(path + "[" + std::to_string(i) + "]", "is " + describe_json(value[i]) + ", outside the float32 range");
      }
      out.push_back(static_cast<float>(v));
    }
    return out;
  }

 private:
  const json& root_;
  std::string file_;
};

// --- graph signatures -------------------------------------------------------------

// One axis of the contract: a fixed size, or a symbolic axis with a role
// ("B", "H", "F", "T", ...). Inputs with the same role must share the axis
// name, different roles must not (ORT checks sizes by name). Role "?" is a
// symbolic axis of any name (outputs: "4*tokens").
struct ExpectedDim {
  int64_t size = -1;
  std::string role;
  std::string why;  // what a fixed size is, e.g. "token_dim"
};

struct ExpectedTensor {
  std::string name;
  std::string dtype;
  std::vector<ExpectedDim> dims;
};

struct ExpectedGraph {
  std::string key;
  std::vector<ExpectedTensor> inputs;
  std::vector<ExpectedTensor> outputs;
};

ExpectedDim fixed(size_t size, const std::string& why) { return {static_cast<int64_t>(size), "", why}; }
ExpectedDim symbolic(const std::string& role) { return {-1, role, ""}; }

std::string format_expected(const ExpectedTensor& t) {
  std::ostringstream out;
  out << t.dtype << " [";
  for (size_t i = 0; i < t.dims.size(); ++i) {
    if (i) out << ", ";
    if (t.dims[i].size >= 0) {
      out << t.dims[i].size;
      if (!t.dims[i].why.empty()) out << " (" << t.dims[i].why << ")";
    } else {
      out << (t.dims[i].role == "?" ? "symbolic" : t.dims[i].role);
    }
  }
  out << ']';
  return out.str();
}

std::string format_info(const TensorInfo& t) {
  std::ostringstream out;
  out << t.dtype << " [";
  for (size_t i = 0; i < t.shape.size(); ++i) {
    if (i) out << ", ";
    if (t.shape[i] >= 0) {
      out << t.shape[i];
    } else {
      const std::string& s = i < t.symbolic_dims.size() ? t.symbolic_dims[i] : std::string();
      out << (s.empty() ? "?" : s);
    }
  }
  out << ']';
  return out.str();
}

std::string list_names(const std::vector<TensorInfo>& list) {
  std::string out;
  for (const TensorInfo& t : list) out += (out.empty() ? "" : ", ") + in_quotes(t.name) + " " + format_info(t);
  return out.empty() ? "none" : out;
}

// graphs.<key>.inputs / outputs of model.json as TensorInfo (symbolic axes
// by name, -1 in shape).
std::vector<TensorInfo> parse_signature(const Manifest& m, const std::string& path) {
  const json& list = m.at(path);
  if (!list.is_array()) m.fail(path, "must be an array of {name, dtype, shape}, found " + describe_json(list));
  std::vector<TensorInfo> out;
  std::set<std::string> names;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string at = path + "[" + std::to_string(i) + "]";
    const json& entry = list[i];
    if (!entry.is_object()) m.fail(at, "must be an object {name, dtype, shape}, found " + describe_json(entry));
    TensorInfo info;
    if (!entry.contains("name")) throw Error(m.file() + ": missing field " + at + ".name");
    if (!entry.contains("dtype")) throw Error(m.file() + ": missing field " + at + ".dtype");
    if (!entry.contains("shape")) throw Error(m.file() + ": missing field " + at + ".shape");
    info.name = m.string(entry["name"], at + ".name");
    info.dtype = m.string(entry["dtype"], at + ".dtype");
    const json& shape = entry["shape"];
    if (!shape.is_array()) m.fail(at + ".shape", "must be an array, found " + describe_json(shape));
    for (size_t d = 0; d < shape.size(); ++d) {
      const std::string dim_path = at + ".shape[" + std::to_string(d) + "]";
      if (shape[d].is_string()) {
        const std::string symbol = shape[d].get<std::string>();
        if (symbol.empty()) m.fail(dim_path, "is an empty axis name");
        info.shape.push_back(-1);
        info.symbolic_dims.push_back(symbol);
      } else {
        info.shape.push_back(m.integer(shape[d], dim_path, 0));
        info.symbolic_dims.emplace_back();
      }
    }
    if (!names.insert(info.name).second) m.fail(at + ".name", "repeats the name " + in_quotes(info.name));
    out.push_back(std::move(info));
  }
  return out;
}

// model.json's signature of one graph against the tensor contract.
void check_contract(const Manifest& m, const GraphSpec& spec, const ExpectedGraph& expected) {
  const auto check_list = [&](const std::vector<TensorInfo>& found, const std::vector<ExpectedTensor>& wanted,
                              const std::string& kind) {
    const std::string path = "graphs." + spec.key + "." + kind;
    std::map<std::string, std::string> role_to_name;
    std::map<std::string, std::string> name_to_role;
    for (const ExpectedTensor& want : wanted) {
      const auto it =
          std::find_if(found.begin(), found.end(), [&](const TensorInfo& t) { return t.name == want.name; });
      if (it == found.end()) {
        m.fail(path, "has no " + kind.substr(0, kind.size() - 1) + " " + in_quotes(want.name) + " (expected " +
                         format_expected(want) + "; found " + list_names(found) + ")");
      }
      const std::string at = path + " " + in_quotes(want.name);
      if (it->dtype != want.dtype || it->shape.size() != want.dims.size()) {
        m.fail(at, "is " + format_info(*it) + ", expected " + format_expected(want));
      }
      for (size_t d = 0; d < want.dims.size(); ++d) {
        const ExpectedDim& dim = want.dims[d];
        if (dim.size >= 0) {
          if (it->shape[d] != dim.size) {
            m.fail(at, "is " + format_info(*it) + ", expected " + format_expected(want) + " (axis " +
                           std::to_string(d) + " must be " + std::to_string(dim.size) + ")");
          }
          continue;
        }
        if (it->shape[d] >= 0) {
          m.fail(at, "is " + format_info(*it) + ", expected " + format_expected(want) + " (axis " + std::to_string(d) +
                         " must be symbolic)");
        }
        if (dim.role == "?") continue;
        const std::string& symbol = it->symbolic_dims[d];
        const auto [role_it, new_role] = role_to_name.emplace(dim.role, symbol);
        if (!new_role && role_it->second != symbol) {
          m.fail(at, "names axis " + std::to_string(d) + " " + in_quotes(symbol) + ", but another " +
                         kind.substr(0, kind.size() - 1) + " names the same axis (" + dim.role + ") " +
                         in_quotes(role_it->second));
        }
        const auto [name_it, new_name] = name_to_role.emplace(symbol, dim.role);
        if (!new_name && name_it->second != dim.role) {
          m.fail(at, "uses the axis name " + in_quotes(symbol) + " for two different axes (" + name_it->second +
                         " and " + dim.role + ")");
        }
      }
    }
    for (const TensorInfo& t : found) {
      const bool known =
          std::any_of(wanted.begin(), wanted.end(), [&](const ExpectedTensor& w) { return w.name == t.name; });
      if (!known) {
        std::string names;
        for (const ExpectedTensor& w : wanted) names += (names.empty() ? "" : ", ") + in_quotes(w.name);
        m.fail(path, "has an unexpected " + kind.substr(0, kind.size() - 1) + " " + in_quotes(t.name) + " (the " +
                         spec.key + " graph takes " + names + ")");
      }
    }
  };
  check_list(spec.inputs, expected.inputs, "inputs");
  check_list(spec.outputs, expected.outputs, "outputs");
}

// A loaded graph's real inputs and outputs against model.json's signature.
void check_graph(const OnnxSession& session, const GraphSpec& spec, const std::string& manifest_file) {
  const std::string graph = session.name() + " (graph '" + spec.key + "')";
  const auto check_list = [&](const std::vector<TensorInfo>& actual, const std::vector<TensorInfo>& declared,
                              const std::string& kind) {
    const std::string singular = kind.substr(0, kind.size() - 1);
    for (const TensorInfo& want : declared) {
      const auto it =
          std::find_if(actual.begin(), actual.end(), [&](const TensorInfo& t) { return t.name == want.name; });
      if (it == actual.end()) {
        throw Error(graph + ": signature mismatch: " + manifest_file + " (graphs." + spec.key + "." + kind +
                    ") declares " + singular + " " + in_quotes(want.name) + " " + format_info(want) +
                    ", but the graph has no such " + singular + " (its " + kind + ": " + list_names(actual) +
                    "); is this the right file?");
      }
      bool same = it->dtype == want.dtype && it->shape.size() == want.shape.size();
      for (size_t d = 0; same && d < want.shape.size(); ++d) {
        if (want.shape[d] >= 0) {
          same = it->shape[d] == want.shape[d];
        } else {
          same = it->shape[d] < 0 && it->symbolic_dims[d] == want.symbolic_dims[d];
        }
      }
      if (!same) {
        throw Error(graph + ": signature mismatch: " + singular + " " + in_quotes(want.name) + " is " +
                    format_info(*it) + " in the graph, but " + manifest_file + " (graphs." + spec.key + "." + kind +
                    ") declares " + format_info(want));
      }
    }
    for (const TensorInfo& t : actual) {
      const bool declared_here =
          std::any_of(declared.begin(), declared.end(), [&](const TensorInfo& w) { return w.name == t.name; });
      if (!declared_here) {
        throw Error(graph + ": signature mismatch: the graph has " + singular + " " + in_quotes(t.name) + " " +
                    format_info(t) + " that " + manifest_file + " (graphs." + spec.key + "." + kind +
                    ") does not declare");
      }
    }
  };
  check_list(session.inputs(), spec.inputs, "inputs");
  check_list(session.outputs(), spec.outputs, "outputs");
}

// A file model.json names must be a plain relative path inside the package
// (an untrusted package must not make the runtime read elsewhere).
void check_file_name(const Manifest& m, const std::string& path, const std::string& file) {
  const std::string reason = onnx_scan::unsafe_path_reason(file);
  if (!reason.empty()) {
    m.fail(path, "is " + in_quotes(file) + ", which " + reason + " (expected a file name inside the package)");
  }
}

std::vector<std::string> string_list(const Manifest& m, const std::string& path) {
  const json& value = m.at(path);
  if (!value.is_array()) m.fail(path, "must be an array of strings, found " + describe_json(value));
  std::vector<std::string> out;
  for (size_t i = 0; i < value.size(); ++i) out.push_back(m.string(value[i], path + "[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------

struct ModelPackage::Impl {
  std::string name;
  std::string model_json;
  double fps = 0.0;
  FeatureLayout layout;
  std::unique_ptr<Skeleton> skeleton;
  std::vector<std::string> contact_joints;
  TokenSizes tokens;
  std::unique_ptr<Normalization> feature_norm;
  std::unique_ptr<Normalization> latent_norm;
  DiffusionSchedule schedule;
  SamplingDefaults defaults;
  DenoiserSizes denoiser_sizes;
  TextSettings text;
  std::map<std::string, GraphSpec> graphs;
  std::shared_ptr<OnnxEnvironment> env;
  // Sessions after the environment: destroyed first.
  std::unique_ptr<OnnxSession> history;
  std::unique_ptr<OnnxSession> goals;
  std::unique_ptr<OnnxSession> denoiser;
  std::unique_ptr<OnnxSession> decoder;
  std::unique_ptr<OnnxSession> encoder;
  std::unique_ptr<TextEncoder> text_encoder;

  static std::unique_ptr<Impl> load(const FileSource& source, const std::string& name, const PackageOptions& options);
  void parse(const Manifest& m);
  std::vector<ExpectedGraph> contract() const;
};

void ModelPackage::Impl::parse(const Manifest& m) {
  // --- format ---------------------------------------------------------------
  const std::string format = m.string("format");
  if (format != kPackageFormat) {
    m.fail("format",
           "is " + in_quotes(format) + ", expected " + in_quotes(kPackageFormat) + " (not an ARDY model package)");
  }
  const json& version = m.at("format_version");
  if (!version.is_number_integer() || version.get<int64_t>() != kPackageFormatVersion) {
    m.fail("format_version", "is " + describe_json(version) + ", expected " + std::to_string(kPackageFormatVersion) +
                                 " (this runtime reads format version " + std::to_string(kPackageFormatVersion) +
                                 " only; re-export the package or update the runtime" +
                                 (version.is_number_integer() && version.get<int64_t>() == 1
                                      ? std::string("; a version 1 package's weights re-export with "
                                                    "'ardy-export recover-checkpoint' then 'ardy-export export'")
                                      : std::string()) +
                                 ")");
  }
  fps = m.number("fps");
  if (!(fps > 0.0) || fps > 1000.0) m.fail("fps", "is " + describe_json(m.at("fps")) + ", expected 0 < fps <= 1000");

  // --- skeleton ---------------------------------------------------------------
  const std::vector<std::string> joints = string_list(m, "skeleton.joints");
  if (joints.empty()) m.fail("skeleton.joints", "is empty, expected at least one joint");
  if (joints.size() > Skeleton::kMaxJoints) {
    m.fail("skeleton.joints", "has " + std::to_string(joints.size()) + " joints, more than the " +
                                  std::to_string(Skeleton::kMaxJoints) + " supported");
  }
  const size_t joint_count = joints.size();
  const std::string per_joint = "one per joint, " + std::to_string(joint_count) + " in skeleton.joints";
  const json& parents_json = m.array("skeleton.parents", joint_count, per_joint);
  std::vector<int> parents;
  for (size_t j = 0; j < joint_count; ++j) {
    parents.push_back(static_cast<int>(
        m.integer(parents_json[j], "skeleton.parents[" + std::to_string(j) + "]", -1, int64_t(joint_count) - 1)));
  }
  const json& offsets_json = m.array("skeleton.rest_offsets", joint_count, per_joint);
  std::vector<glm::vec3> offsets;
  for (size_t j = 0; j < joint_count; ++j) {
    const std::string at = "skeleton.rest_offsets[" + std::to_string(j) + "]";
    const json& row = offsets_json[j];
    if (!row.is_array() || row.size() != 3) m.fail(at, "must be [x, y, z], found " + describe_json(row));
    offsets.emplace_back(static_cast<float>(m.number(row[0], at + "[0]")),
                         static_cast<float>(m.number(row[1], at + "[1]")),
                         static_cast<float>(m.number(row[2], at + "[2]")));
  }
  try {
    skeleton = std::make_unique<Skeleton>(joints, parents, offsets);
  } catch (const Error& e) {
    throw Error(m.file() + ": " + e.what());
  }

  // --- features -----------------------------------------------------------------
  try {
    layout = FeatureLayout::from_json(m.at("features.slices"), joint_count);
  } catch (const Error& e) {
    if (!m.has("features.slices")) throw;
    throw Error(m.file() + ": features.slices: " + e.what());
  }
  const size_t feature_size = m.size("features.size");
  if (feature_size != layout.feature_size) {
    m.fail("features.size", "is " + std::to_string(feature_size) + ", expected " + std::to_string(layout.feature_size) +
                                " (the end of features.slices)");
  }
  const auto check_span = [&](const std::string& path, FeatureSlice expected, const std::string& what) {
    if (!m.has(path)) return;  // optional: the slices already say it
    const json& span = m.at(path);
    const bool ok = span.is_array() && span.size() == 2 && span[0].is_number_integer() && span[1].is_number_integer() &&
                    span[0].get<int64_t>() == int64_t(expected.start) &&
                    span[1].get<int64_t>() == int64_t(expected.stop());
    if (!ok) {
      m.fail(path, "is " + span.dump() + ", expected [" + std::to_string(expected.start) + ", " +
                       std::to_string(expected.stop()) + "] (" + what + " of features.slices)");
    }
  };
  check_span("features.root", layout.root(), "root_position + heading");
  check_span("features.body", layout.body(), "everything but the root");
  contact_joints = string_list(m, "features.contact_joints");
  if (contact_joints.size() != layout.contact_count()) {
    m.fail("features.contact_joints", "has " + std::to_string(contact_joints.size()) + " joints, expected " +
                                          std::to_string(layout.contact_count()) +
                                          " (the size of features.slices.foot_contacts)");
  }
  for (size_t i = 0; i < contact_joints.size(); ++i) {
    if (!skeleton->find(contact_joints[i])) {
      m.fail("features.contact_joints[" + std::to_string(i) + "]",
             "is " + in_quotes(contact_joints[i]) + ", which is not a joint of skeleton.joints");
    }
  }

  // --- tokens ---------------------------------------------------------------------
  tokens.patch = m.size("tokens.patch");
  tokens.latent_dim = m.size("tokens.latent_dim");
  tokens.token_dim = m.size("tokens.token_dim");
  const size_t root_size = layout.root_size();
  const size_t expected_token_dim = root_size * tokens.patch + tokens.latent_dim;
  if (tokens.token_dim != expected_token_dim) {
    m.fail("tokens.token_dim", "is " + std::to_string(tokens.token_dim) + ", expected " + std::to_string(root_size) +
                                   "*patch + latent_dim = " + std::to_string(expected_token_dim));
  }
  tokens.window = m.size("tokens.window");
  tokens.max_history = m.size("tokens.max_history", 0);
  tokens.max_future = m.size("tokens.max_future", 0);
  tokens.goal_dim = m.size("tokens.goal_dim");
  if (tokens.goal_dim != tokens.patch * layout.feature_size) {
    m.fail("tokens.goal_dim", "is " + std::to_string(tokens.goal_dim) + ", expected patch * features.size = " +
                                  std::to_string(tokens.patch * layout.feature_size));
  }
  if (m.has("latent.dim") && m.size("latent.dim") != tokens.latent_dim) {
    m.fail("latent.dim", "is " + std::to_string(m.size("latent.dim")) +
                             ", expected tokens.latent_dim = " + std::to_string(tokens.latent_dim));
  }

  // --- normalization ----------------------------------------------------------------
  const std::string per_feature = "one per feature, features.size = " + std::to_string(feature_size);
  const std::string per_latent = "one per latent dim, tokens.latent_dim = " + std::to_string(tokens.latent_dim);
  feature_norm = std::make_unique<Normalization>(m.floats("normalization.mean", feature_size, per_feature),
                                                 m.floats("normalization.std", feature_size, per_feature),
                                                 m.file() + ": normalization (mean, std)");
  latent_norm = std::make_unique<Normalization>(m.floats("normalization.latent_mean", tokens.latent_dim, per_latent),
                                                m.floats("normalization.latent_std", tokens.latent_dim, per_latent),
                                                m.file() + ": normalization (latent_mean, latent_std)");

  // --- diffusion ----------------------------------------------------------------------
  const size_t num_steps = m.size("diffusion.num_steps", 1, 100000);
  const json& alphas = m.array("diffusion.alphas_cumprod", num_steps, "one per step, diffusion.num_steps");
  schedule.alphas_cumprod.clear();
  for (size_t t = 0; t < num_steps; ++t) {
    const std::string at = "diffusion.alphas_cumprod[" + std::to_string(t) + "]";
    const double a = m.number(alphas[t], at);
    if (!(a > 0.0 && a < 1.0)) m.fail(at, "is " + describe_json(alphas[t]) + ", expected 0 < value < 1");
    if (t > 0 && a > schedule.alphas_cumprod.back()) {
      m.fail(at, "is " + describe_json(alphas[t]) + ", larger than the step before (" + describe_json(alphas[t - 1]) +
                     "); alphas_cumprod must not increase");
    }
    schedule.alphas_cumprod.push_back(a);
  }
  const std::string prediction = m.string("diffusion.prediction");
  if (prediction != "x0") m.fail("diffusion.prediction", "is " + in_quotes(prediction) + ", expected 'x0'");
  const std::string sampler = m.string("diffusion.sampler");
  if (sampler != "ddim_eta0") m.fail("diffusion.sampler", "is " + in_quotes(sampler) + ", expected 'ddim_eta0'");

  // --- sampling defaults -------------------------------------------------------------------
  defaults.steps = m.size("sampling.default_steps", 1, int64_t(num_steps));
  defaults.w_text = static_cast<float>(m.number("sampling.w_text"));
  defaults.w_con = static_cast<float>(m.number("sampling.w_con"));
  defaults.decode_context_tokens = m.size("sampling.decode_context_tokens", 0);
  if (m.has("sampling.output_smoothing_frames")) {
    const double sigma = m.number("sampling.output_smoothing_frames");
    if (!(sigma >= 0.0 && sigma <= kMaxSmoothingFrames)) {
      m.fail("sampling.output_smoothing_frames", "is " + describe_json(sigma) + ", expected 0.." +
                                                     describe_json(kMaxSmoothingFrames) + " frames");
    }
    defaults.output_smoothing_frames = sigma;
  }
  if (m.has("sampling.interpolate_root")) defaults.interpolate_root = m.boolean("sampling.interpolate_root");
  if (m.has("sampling.path_guidance_scale")) {
    const double scale = m.number("sampling.path_guidance_scale");
    if (!path_guidance_scale_in_range(scale)) {
      m.fail("sampling.path_guidance_scale", "is " + describe_json(scale) + ", expected a number in (0, 1]");
    }
    defaults.path_guidance_scale = static_cast<float>(scale);
  }
  if (m.has("sampling.text_only_guidance_scale")) {
    const double scale = m.number("sampling.text_only_guidance_scale");
    if (!text_only_guidance_scale_in_range(scale)) {
      m.fail("sampling.text_only_guidance_scale", "is " + describe_json(scale) + ", expected a number in (0, 4]");
    }
    defaults.text_only_guidance_scale = static_cast<float>(scale);
  }

  // --- denoiser sizes ------------------------------------------------------------------------
  denoiser_sizes.two_stage = m.boolean("denoiser.two_stage");
  if (!m.boolean("denoiser.history_self_only")) {
    m.fail("denoiser.history_self_only",
           "is false, expected true (the history graph's keys and values must not depend on the window)");
  }
  denoiser_sizes.width = m.size("denoiser.width", 1, 1 << 16);
  denoiser_sizes.layers = m.size("denoiser.layers", 1, 1024);
  denoiser_sizes.heads = m.size("denoiser.heads", 1, 1024);
  denoiser_sizes.ff_mult = m.size("denoiser.ff_mult", 1, 1024);
  if (m.has("denoiser.condition_modulation")) {
    denoiser_sizes.condition_modulation = m.boolean("denoiser.condition_modulation");
  }
  const std::string goal_input = m.string("denoiser.window_goal_input");
  if (goal_input == "full") {
    denoiser_sizes.window_goal_dim = tokens.goal_dim;
  } else if (goal_input == "body") {
    denoiser_sizes.window_goal_dim = tokens.goal_dim - tokens.root_token_dim();
  } else {
    m.fail("denoiser.window_goal_input", "is " + in_quotes(goal_input) + ", expected 'full' or 'body'");
  }
  if (denoiser_sizes.width % denoiser_sizes.heads != 0) {
    m.fail("denoiser.heads", "is " + std::to_string(denoiser_sizes.heads) + ", expected a divisor of denoiser.width (" +
                                 std::to_string(denoiser_sizes.width) + ")");
  }

  // --- text ---------------------------------------------------------------------------------
  text.graph_file = m.string("text.graph");
  check_file_name(m, "text.graph", text.graph_file);
  text.vocab_file = m.string("text.vocab");
  check_file_name(m, "text.vocab", text.vocab_file);
  text.embedding_size = m.size("text.embedding_size");
  WordPieceOptions& wp = text.tokenizer;
  wp.max_tokens = m.size("text.max_tokens", 2, 1 << 20);
  wp.lower_case = m.boolean("text.lower_case");
  wp.strip_accents = m.boolean("text.strip_accents");
  wp.split_cjk_ideographs = m.has("text.split_cjk_chars") ? m.boolean("text.split_cjk_chars") : true;
  wp.max_chars_per_word = m.size("text.max_chars_per_word");
  wp.continuation_prefix = m.string("text.wordpiece_prefix");
  if (m.has("text.clean_text") && !m.boolean("text.clean_text")) {
    m.fail("text.clean_text", "is false; this runtime's tokenizer always cleans the text (expected true)");
  }
  if (m.has("text.truncation") && m.string("text.truncation") != "right") {
    m.fail("text.truncation", "is " + in_quotes(m.string("text.truncation")) + ", expected 'right'");
  }
  if (m.has("text.padding.side") && m.string("text.padding.side") != "right") {
    m.fail("text.padding.side", "is " + in_quotes(m.string("text.padding.side")) + ", expected 'right'");
  }
  wp.pad_token = m.string("text.special_tokens.pad.token");
  wp.unk_token = m.string("text.special_tokens.unk.token");
  wp.cls_token = m.string("text.special_tokens.cls.token");
  wp.sep_token = m.string("text.special_tokens.sep.token");
  const json& specials = m.at("text.special_tokens");
  if (!specials.is_object()) m.fail("text.special_tokens", "must be an object, found " + describe_json(specials));
  wp.special_tokens.clear();
  for (auto it = specials.begin(); it != specials.end(); ++it) {
    wp.special_tokens.push_back(m.string("text.special_tokens." + it.key() + ".token"));
  }

  // --- graphs -----------------------------------------------------------------------------------
  for (const char* key : {"history", "goals", "denoiser", "decoder", "encoder", "text_encoder"}) {
    GraphSpec spec;
    spec.key = key;
    const std::string base = std::string("graphs.") + key;
    spec.file = m.string(base + ".file");
    check_file_name(m, base + ".file", spec.file);
    spec.inputs = parse_signature(m, base + ".inputs");
    spec.outputs = parse_signature(m, base + ".outputs");
    graphs.emplace(key, std::move(spec));
  }
  if (graphs.at("text_encoder").file != text.graph_file) {
    m.fail("graphs.text_encoder.file", "is " + in_quotes(graphs.at("text_encoder").file) + ", but text.graph is " +
                                           in_quotes(text.graph_file) + " (expected the same file)");
  }
  for (const ExpectedGraph& expected : contract()) check_contract(m, graphs.at(expected.key), expected);
}

std::vector<ExpectedGraph> ModelPackage::Impl::contract() const {
  const size_t c = tokens.window, d = tokens.token_dim, pm = tokens.goal_dim, e = text.embedding_size;
  const size_t body = layout.body_size(), root = layout.root_size(), l = tokens.latent_dim;
  const ExpectedDim b = symbolic("B");
  const ExpectedDim cd = fixed(c, "tokens.window");
  const ExpectedDim dd = fixed(d, "tokens.token_dim");
  const ExpectedDim gd = fixed(pm, "tokens.goal_dim");
  const DenoiserSizes& ds = denoiser_sizes;
  const std::vector<ExpectedDim> keys_values{b,
                                             fixed(ds.cached_layers(), "stages * denoiser.layers"),
                                             fixed(2, "keys and values"),
                                             fixed(ds.heads, "denoiser.heads"),
                                             symbolic("H"),
                                             fixed(ds.head_dim(), "denoiser.width / heads")};
  std::vector<ExpectedGraph> out;
  out.push_back({"history",
                 {{"history", "float32", {b, symbolic("H"), dd}}, {"history_mask", "float32", {b, symbolic("H")}}},
                 {{"history_kv", "float32", keys_values}}});
  const ExpectedDim stages = fixed(ds.stages(), "stages (denoiser.two_stage)");
  const ExpectedDim width = fixed(ds.width, "denoiser.width");
  const ExpectedDim root_dim = fixed(tokens.root_token_dim(), "5 * tokens.patch");
  out.push_back({"goals",
                 {{"window_goal", "float32", {b, cd, gd}},
                  {"window_goal_mask", "float32", {b, cd, gd}},
                  {"future_goal", "float32", {b, symbolic("F"), gd}},
                  {"future_goal_mask", "float32", {b, symbolic("F"), gd}}},
                 {{"window_root_goal", "float32", {b, cd, root_dim}},
                  {"window_root_mask", "float32", {b, cd, root_dim}},
                  {"window_goal_embedding", "float32", {b, stages, cd, width}},
                  {"future_embedding", "float32", {b, stages, symbolic("F"), width}}}});
  out.push_back({"denoiser",
                 {{"x_t", "float32", {b, cd, dd}},
                  {"step", "int64", {b}},
                  {"text_embedding", "float32", {b, fixed(e, "text.embedding_size")}},
                  {"text_keep", "float32", {b}},
                  {"history_kv", "float32", keys_values},
                  {"history_mask", "float32", {b, symbolic("H")}},
                  {"window_root_goal", "float32", {b, cd, root_dim}},
                  {"window_root_mask", "float32", {b, cd, root_dim}},
                  {"window_goal_embedding", "float32", {b, stages, cd, width}},
                  {"future_embedding", "float32", {b, stages, symbolic("F"), width}},
                  {"future_mask", "float32", {b, symbolic("F")}},
                  {"constraint_keep", "float32", {b}}},
                 {{"x0", "float32", {b, cd, dd}}}});
  out.push_back({"decoder",
                 {{"tokens", "float32", {b, symbolic("T"), dd}},
                  {"prev_root", "float32", {b, fixed(root, "root size")}},
                  {"prev_root_valid", "float32", {b}}},
                 {{"body", "float32", {b, symbolic("?"), fixed(body, "body features")}}}});
  out.push_back({"encoder",
                 {{"body", "float32", {b, symbolic("T"), fixed(body, "body features")}}},
                 {{"latent", "float32", {b, symbolic("?"), fixed(l, "tokens.latent_dim")}}}});
  out.push_back({"text_encoder",
                 {{"input_ids", "int64", {b, symbolic("T")}}, {"attention_mask", "int64", {b, symbolic("T")}}},
                 {{"embedding", "float32", {b, fixed(e, "text.embedding_size")}}}});
  return out;
}

std::unique_ptr<ModelPackage::Impl> ModelPackage::Impl::load(const FileSource& source, const std::string& name,
                                                             const PackageOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->name = name;
  const std::string manifest_file = source.where(kModelFile);
  impl->model_json = source.read(kModelFile, "the package description model.json", kMaxModelJsonBytes);
  json root;
  try {
    root = json::parse(impl->model_json);
  } catch (const json::exception& e) {
    throw Error(manifest_file + ": not valid JSON (" + e.what() + ")");
  }
  if (!root.is_object()) throw Error(manifest_file + ": expected a JSON object, found " + describe_json(root));
  const Manifest manifest(root, manifest_file);
  impl->parse(manifest);

  if (options.environment) {
    impl->env = options.environment;
  } else {
    EnvironmentOptions env;
    env.shared_pool = options.shared_thread_pool;
    env.shared_pool_threads = options.session.intra_op_threads;
    env.allow_spinning = options.session.allow_spinning;
    impl->env = OnnxEnvironment::create(env);
  }
  const auto load_graph = [&](const std::string& key) {
    const GraphSpec& spec = impl->graphs.at(key);
    std::unique_ptr<OnnxSession> session;
    try {
      session = std::make_unique<OnnxSession>(source.session(impl->env, spec.file, options.session));
    } catch (const Error& e) {
      throw Error(std::string(e.what()) + " (graph '" + key + "', " + manifest_file + " graphs." + key + ".file)");
    }
    check_graph(*session, spec, manifest_file);
    return session;
  };
  impl->history = load_graph("history");
  impl->goals = load_graph("goals");
  impl->denoiser = load_graph("denoiser");
  impl->decoder = load_graph("decoder");
  impl->encoder = load_graph("encoder");
  std::unique_ptr<OnnxSession> text_session = load_graph("text_encoder");

  const std::string vocab_bytes =
      source.read(impl->text.vocab_file, "the WordPiece vocabulary (text.vocab)", kMaxVocabBytes);
  WordPieceTokenizer tokenizer = WordPieceTokenizer::from_memory(
      vocab_bytes.data(), vocab_bytes.size(), source.where(impl->text.vocab_file), impl->text.tokenizer);
  // The special tokens' ids in model.json must be the vocabulary's.
  const json& specials = manifest.at("text.special_tokens");
  for (auto it = specials.begin(); it != specials.end(); ++it) {
    const std::string path = "text.special_tokens." + it.key();
    if (!it->contains("id")) continue;
    const int64_t id = manifest.integer((*it)["id"], path + ".id", 0, std::numeric_limits<int32_t>::max());
    const std::string token = manifest.string(path + ".token");
    const auto found = tokenizer.find_token(token);
    if (!found || *found != id) {
      manifest.fail(path + ".id", "is " + std::to_string(id) + ", but " + source.where(impl->text.vocab_file) +
                                      " has " + in_quotes(token) +
                                      (found ? " at id " + std::to_string(*found) : std::string(" nowhere")));
    }
  }
  if (manifest.has("text.padding.id")) {
    const int64_t pad =
        manifest.integer(manifest.at("text.padding.id"), "text.padding.id", 0, std::numeric_limits<int32_t>::max());
    if (pad != tokenizer.pad_id()) {
      manifest.fail("text.padding.id", "is " + std::to_string(pad) + ", expected the id of the pad token (" +
                                           std::to_string(tokenizer.pad_id()) + ")");
    }
  }
  if (manifest.has("text.vocab_size") && manifest.size("text.vocab_size") != tokenizer.vocab_size()) {
    manifest.fail("text.vocab_size", "is " + std::to_string(manifest.size("text.vocab_size")) + ", but " +
                                         source.where(impl->text.vocab_file) + " has " +
                                         std::to_string(tokenizer.vocab_size()) + " tokens");
  }
  TextEncoderOptions text_options = options.text;
  text_options.input_ids_name = "input_ids";
  text_options.attention_mask_name = "attention_mask";
  text_options.embedding_name = "embedding";
  impl->text_encoder =
      std::make_unique<TextEncoder>(std::move(tokenizer), std::move(*text_session), std::move(text_options));
  if (impl->text_encoder->embedding_size() != impl->text.embedding_size) {
    manifest.fail("text.embedding_size", "is " + std::to_string(impl->text.embedding_size) + ", but " +
                                             impl->text_encoder->session().name() + " gives " +
                                             std::to_string(impl->text_encoder->embedding_size()));
  }
  return impl;
}

// Files read on demand through a caller's function (an engine's file system).
class ReaderSource final : public FileSource {
 public:
  ReaderSource(const PackageFileReader& read, std::string name) : read_(read), name_(std::move(name)) {}

  std::string where(const std::string& file) const override { return name_ + "/" + file; }

  std::string read(const std::string& file, const std::string& expected, size_t max_bytes) const override {
    std::string bytes = read_(file);
    if (bytes.size() > max_bytes) {
      throw Error(where(file) + ": " + std::to_string(bytes.size()) + " bytes, larger than the " +
                  std::to_string(max_bytes) + " bytes allowed for " + expected);
    }
    return bytes;
  }

  OnnxSession session(std::shared_ptr<OnnxEnvironment> env, const std::string& file,
                      const SessionOptions& options) const override {
    const std::string bytes = read(file, "an ONNX model", kMaxGraphBytes);
    check_external_data(bytes.data(), bytes.size(), where(file), false);
    return OnnxSession::from_memory(std::move(env), bytes.data(), bytes.size(), where(file), options);
  }

 private:
  const PackageFileReader& read_;
  std::string name_;
};

// ---------------------------------------------------------------------------

ModelPackage ModelPackage::from_reader(const PackageFileReader& read, const std::string& name,
                                       const PackageOptions& options) {
  if (!read) throw Error(name + ": no file reader given");
  const ReaderSource source(read, name);
  return ModelPackage(Impl::load(source, name, options));
}

ModelPackage ModelPackage::from_folder(const std::string& folder, const PackageOptions& options) {
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    throw Error(folder + ": not a folder (expected a model package folder with model.json)");
  }
  const FolderSource source(folder);
  return ModelPackage(Impl::load(source, folder, options));
}

ModelPackage ModelPackage::from_memory(const PackageFileViews& files, const std::string& name,
                                       const PackageOptions& options) {
  const MemorySource source(files, name);
  return ModelPackage(Impl::load(source, name, options));
}

ModelPackage ModelPackage::from_memory(const PackageFiles& files, const std::string& name,
                                       const PackageOptions& options) {
  PackageFileViews views;
  for (const auto& [file, bytes] : files) views.emplace(file, ByteView{bytes.data(), bytes.size()});
  return from_memory(views, name, options);
}

ModelPackage::ModelPackage(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ModelPackage::ModelPackage(ModelPackage&&) noexcept = default;
ModelPackage& ModelPackage::operator=(ModelPackage&&) noexcept = default;
ModelPackage::~ModelPackage() = default;

const ModelPackage::Impl& ModelPackage::impl() const {
  if (!impl_) throw Error("ModelPackage: used after being moved from");
  return *impl_;
}

const std::string& ModelPackage::name() const { return impl().name; }
const std::string& ModelPackage::model_json() const { return impl().model_json; }
double ModelPackage::fps() const { return impl().fps; }
const FeatureLayout& ModelPackage::layout() const { return impl().layout; }
const Skeleton& ModelPackage::skeleton() const { return *impl().skeleton; }
const std::vector<std::string>& ModelPackage::contact_joints() const { return impl().contact_joints; }
const TokenSizes& ModelPackage::tokens() const { return impl().tokens; }
const Normalization& ModelPackage::feature_normalization() const { return *impl().feature_norm; }
const Normalization& ModelPackage::latent_normalization() const { return *impl().latent_norm; }
const DiffusionSchedule& ModelPackage::schedule() const { return impl().schedule; }
const SamplingDefaults& ModelPackage::sampling_defaults() const { return impl().defaults; }
const TextSettings& ModelPackage::text_settings() const { return impl().text; }
size_t ModelPackage::text_embedding_size() const { return impl().text.embedding_size; }
const OnnxSession& ModelPackage::history() const { return *impl().history; }
const OnnxSession& ModelPackage::goals() const { return *impl().goals; }
const OnnxSession& ModelPackage::denoiser() const { return *impl().denoiser; }
const DenoiserSizes& ModelPackage::denoiser_sizes() const { return impl().denoiser_sizes; }
const OnnxSession& ModelPackage::decoder() const { return *impl().decoder; }
const OnnxSession& ModelPackage::encoder() const { return *impl().encoder; }
const TextEncoder& ModelPackage::text_encoder() const { return *impl().text_encoder; }
const std::shared_ptr<OnnxEnvironment>& ModelPackage::environment() const { return impl().env; }

const GraphSpec& ModelPackage::graph_spec(const std::string& key) const {
  const auto it = impl().graphs.find(key);
  if (it == impl().graphs.end()) {
    throw Error("model package: no graph " + in_quotes(key) + " (graphs: denoiser, decoder, encoder, text_encoder)");
  }
  return it->second;
}

}  // namespace ardy
