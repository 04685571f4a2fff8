#pragma once

// The tiny test package's golden vectors (export_tools/ardy_export/goldens.py):
// goldens.json indexes goldens.bin (name -> dtype, shape, byte offset, little
// endian, packed) and carries the rollout's prompts, constraints and config.
// Also a comparison helper that records the worst error of each check, so
// the parity suites can print them.

#include <catch_amalgamated.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "onnx_session.hpp"
#include "package.hpp"
#include "support/test_data.hpp"

namespace ardy_test {

// The package with golden vectors: tests/data/tiny_package, or the folder in
// the environment variable ARDY_TEST_PACKAGE (a package written by
// ardy_export.goldens.write_test_package with other sizes; run the
// "[parity]" tests with it).
inline std::string tiny_package_dir() {
  const char* other = std::getenv("ARDY_TEST_PACKAGE");
  return other && *other ? std::string(other) : data_path("tiny_package");
}

class Goldens {
 public:
  Goldens() {
    const std::vector<unsigned char> text = read_bytes(tiny_package_dir() + "/goldens.json");
    doc_ = nlohmann::json::parse(text.begin(), text.end());
    blob_ = read_bytes(tiny_package_dir() + "/goldens.bin");
  }

  const nlohmann::json& doc() const { return doc_; }
  bool has(const std::string& name) const { return doc_.at("tensors").contains(name); }

  std::vector<int64_t> shape(const std::string& name) const {
    return entry(name).at("shape").get<std::vector<int64_t>>();
  }
  std::vector<float> floats(const std::string& name) const {
    const nlohmann::json& e = entry(name);
    if (e.at("dtype") != "float32") throw std::runtime_error("golden " + name + " is not float32");
    std::vector<float> out(count(e));
    copy_out(e, out.data(), out.size() * sizeof(float));
    return out;
  }
  std::vector<int64_t> ints(const std::string& name) const {
    const nlohmann::json& e = entry(name);
    if (e.at("dtype") != "int64") throw std::runtime_error("golden " + name + " is not int64");
    std::vector<int64_t> out(count(e));
    copy_out(e, out.data(), out.size() * sizeof(int64_t));
    return out;
  }
  ardy::Tensor tensor(const std::string& name) const {
    const nlohmann::json& e = entry(name);
    if (e.at("dtype") == "int64") return ardy::Tensor::int64(shape(name), ints(name));
    return ardy::Tensor::float32(shape(name), floats(name));
  }

 private:
  const nlohmann::json& entry(const std::string& name) const {
    const nlohmann::json& tensors = doc_.at("tensors");
    if (!tensors.contains(name)) throw std::runtime_error("no golden tensor " + name);
    return tensors.at(name);
  }
  static size_t count(const nlohmann::json& e) {
    size_t n = 1;
    for (int64_t d : e.at("shape").get<std::vector<int64_t>>()) n *= static_cast<size_t>(d);
    return n;
  }
  void copy_out(const nlohmann::json& e, void* out, size_t bytes) const {
    const auto offset = e.at("offset").get<size_t>();
    if (offset + bytes > blob_.size()) throw std::runtime_error("golden tensor beyond goldens.bin");
    if (bytes) std::memcpy(out, blob_.data() + offset, bytes);
  }

  nlohmann::json doc_;
  std::vector<unsigned char> blob_;
};

inline const Goldens& goldens() {
  static const Goldens g;
  return g;
}

// The denoiser graph's inputs for the golden denoiser case: the golden
// history through the package's history graph, the golden goals through its
// goals graph, every other input as saved.
inline std::vector<std::pair<std::string, ardy::Tensor>> golden_denoiser_inputs(const ardy::ModelPackage& package) {
  const auto saved = [](const ardy::OnnxSession& graph) {
    std::vector<std::pair<std::string, ardy::Tensor>> inputs;
    for (const ardy::TensorInfo& info : graph.inputs()) {
      inputs.emplace_back(info.name, goldens().tensor("denoiser/input/" + info.name));
    }
    return inputs;
  };
  std::map<std::string, ardy::Tensor> computed;
  for (const ardy::OnnxSession* graph : {&package.history(), &package.goals()}) {
    const std::vector<ardy::Tensor> outputs = graph->run(saved(*graph), {});
    for (size_t i = 0; i < outputs.size(); ++i) computed.emplace(graph->outputs()[i].name, outputs[i]);
  }
  std::vector<std::pair<std::string, ardy::Tensor>> inputs;
  for (const ardy::TensorInfo& info : package.denoiser().inputs()) {
    const auto it = computed.find(info.name);
    inputs.emplace_back(info.name, it != computed.end() ? it->second : goldens().tensor("denoiser/input/" + info.name));
  }
  return inputs;
}

// Worst absolute error of found against expected, and the scale it is
// judged against (max(1, max |expected|)).
struct Comparison {
  double max_error = 0.0;
  double scale = 1.0;
  size_t worst_index = 0;
  double relative() const { return max_error / scale; }
};

inline Comparison compare(const std::vector<float>& expected, const std::vector<float>& found) {
  REQUIRE(expected.size() == found.size());
  Comparison c;
  for (size_t i = 0; i < expected.size(); ++i) {
    c.scale = std::max(c.scale, std::fabs(double(expected[i])));
    const double err = std::fabs(double(expected[i]) - double(found[i]));
    if (!(err <= c.max_error)) {  // also catches NaN
      c.max_error = std::isnan(err) ? INFINITY : err;
      c.worst_index = i;
    }
  }
  return c;
}

// Prints "parity <what>: max abs error ... (scale ...)" once per run and
// checks it against tolerance * scale.
inline void check_parity(const std::string& what, const std::vector<float>& expected, const std::vector<float>& found,
                         double tolerance = 1e-4) {
  const Comparison c = compare(expected, found);
  std::cout << "parity " << std::left << std::setw(44) << what << " max abs error " << std::scientific
            << std::setprecision(3) << c.max_error << "  (scale " << std::defaultfloat << std::setprecision(4)
            << c.scale << ", index " << c.worst_index << ")\n";
  INFO(what << ": max abs error " << c.max_error << " at " << c.worst_index << ", scale " << c.scale);
  CHECK(c.max_error <= tolerance * c.scale);
}

// The shipped default model (demo_project/addons/ardy/models/default), loaded
// once per test executable: for checks that need a trained model's motion.
inline std::shared_ptr<const ardy::ModelPackage> shipped_package() {
  static const std::shared_ptr<const ardy::ModelPackage> package = [] {
    ardy::PackageOptions options;
    options.session.intra_op_threads = 1;
    return std::make_shared<const ardy::ModelPackage>(ardy::ModelPackage::from_folder(ARDY_SHIPPED_MODEL_DIR, options));
  }();
  return package;
}

// The tiny package, loaded once per test executable.
inline std::shared_ptr<const ardy::ModelPackage> tiny_package() {
  static const std::shared_ptr<const ardy::ModelPackage> package = [] {
    ardy::PackageOptions options;
    options.session.intra_op_threads = 1;
    return std::make_shared<const ardy::ModelPackage>(ardy::ModelPackage::from_folder(tiny_package_dir(), options));
  }();
  return package;
}

}  // namespace ardy_test
