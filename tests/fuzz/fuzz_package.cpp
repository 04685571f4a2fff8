// The model package loader: ModelPackage::from_memory with one file of the
// tiny package (tests/data/tiny_package) replaced by the input. The first
// byte picks the file: below 128 model.json, else 128 + its index in name
// order (goldens.* are not package files); the rest is its bytes.
// Covers model.json parsing and validation, the file-name checks, the
// external-data scan of every graph, ONNX Runtime's loading (not
// instrumented) and the signature checks, and the vocabulary.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_common.hpp"
#include "package.hpp"

namespace {

// Every file of the tiny package but its goldens, in name order (the order
// bench/fuzz.sh writes the seeds in: the selector byte is the index).
const std::vector<std::string>& file_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& entry : std::filesystem::directory_iterator(ardy_fuzz::data_path("tiny_package"))) {
      const std::string name = entry.path().filename().string();
      if (entry.is_regular_file() && name.rfind("goldens.", 0) != 0) out.push_back(name);
    }
    std::sort(out.begin(), out.end());
    return out;
  }();
  return names;
}

const ardy::PackageFiles& tiny_files() {
  static const ardy::PackageFiles files = [] {
    ardy::PackageFiles out;
    for (const std::string& name : file_names()) {
      out.emplace(name, ardy_fuzz::read_bytes(ardy_fuzz::data_path("tiny_package/") + name));
    }
    return out;
  }();
  return files;
}

const ardy::PackageOptions& options() {
  static const ardy::PackageOptions o = [] {
    ardy::PackageOptions out;
    out.session.intra_op_threads = 1;
    out.environment = ardy::OnnxEnvironment::create(ardy::EnvironmentOptions{});  // one for all runs
    return out;
  }();
  return o;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  ardy::PackageFileViews views;
  for (const auto& [name, bytes] : tiny_files()) views.emplace(name, ardy::ByteView{bytes.data(), bytes.size()});
  // Selector < 128: model.json (most inputs: a refused model.json is fast, a
  // loaded package takes its six ONNX Runtime sessions); else file (selector - 128).
  static const std::string kModelJson = "model.json";
  const std::string& replaced = data[0] & 0x80 ? file_names()[(data[0] & 0x7f) % file_names().size()] : kModelJson;
  views[replaced] = ardy::ByteView{data + 1, size - 1};
  ardy_fuzz::refusals_allowed([&] {
    const ardy::ModelPackage package = ardy::ModelPackage::from_memory(views, "fuzz", options());
    if (package.skeleton().joint_count() == 0) ardy_fuzz::broken("a package loaded with no joints");
  });
  return 0;
}
