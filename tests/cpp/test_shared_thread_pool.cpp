// One intra-op pool shared by every graph of a package (PackageOptions::
// shared_thread_pool, EnvironmentOptions). ONNX Runtime keeps one environment
// per process, so this runs in its own executable: each test case starts with
// no environment alive.

#include <catch_amalgamated.hpp>

#include <memory>
#include <vector>

#include "generation_cpu.hpp"
#include "onnx_session.hpp"
#include "package.hpp"
#include "rollout.hpp"
#include "sampler.hpp"
#include "support/error_message.hpp"
#include "support/goldens.hpp"

using ardy::ModelPackage;
using ardy::PackageOptions;
using ardy_test::error_message;
using Catch::Matchers::ContainsSubstring;

namespace {

std::shared_ptr<const ModelPackage> load(bool shared_pool) {
  PackageOptions options;
  // One thread: ONNX Runtime's pool threads are not instrumented, and
  // ThreadSanitizer reads their lock-free hand-offs as races. The pool and
  // the sessions that use it are the same with more threads.
  options.session.intra_op_threads = 1;
  options.session.allow_spinning = shared_pool;
  options.shared_thread_pool = shared_pool;
  return std::make_shared<const ModelPackage>(ModelPackage::from_folder(ardy_test::tiny_package_dir(), options));
}

std::vector<float> first_window(const std::shared_ptr<const ModelPackage>& package) {
  ardy::Rollout rollout(package);
  rollout.add_prompt(0, "a person walks");
  return rollout.generate_next_window().features;
}

}  // namespace

TEST_CASE("a package whose graphs share one spinning thread pool gives the same motion", "[onnx][threads]") {
  const auto shared = load(true);
  CHECK(shared->environment()->shared_pool());
  const std::vector<float> a = first_window(shared);
  // A second package in the same process joins ONNX Runtime's one environment
  // and keeps a pool per graph.
  const auto own = load(false);
  CHECK_FALSE(own->environment()->shared_pool());
  const std::vector<float> b = first_window(own);
  REQUIRE(a.size() == b.size());
  double worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, double(std::abs(a[i] - b[i])));
  CHECK(worst < 1e-4);
}

TEST_CASE("a shared pool asked for after an environment without one is refused clearly", "[onnx][errors]") {
  const auto own = load(false);
  CHECK_THAT(error_message([] { load(true); }), ContainsSubstring("shared thread pool"));
  // The first package is unaffected.
  CHECK_FALSE(first_window(own).empty());
}

TEST_CASE("the shared pool's threads count as generation CPU time", "[onnx][threads][cpu]") {
  PackageOptions options;
  options.session.intra_op_threads = 2;  // the calling thread and one pool thread
  options.session.allow_spinning = false;
  options.shared_thread_pool = true;
  const auto shipped = std::make_shared<const ModelPackage>(ModelPackage::from_folder(ARDY_SHIPPED_MODEL_DIR, options));
  REQUIRE(shipped->environment()->shared_pool());
  // This thread is not a generation thread: what is counted is the pool's.
  const double before = ardy::generation_cpu_seconds();
  const double caller_before = ardy::thread_cpu_seconds();
  ardy::Rollout rollout(shipped);
  rollout.add_prompt(0, "walk forward");
  for (int window = 0; window < 3; ++window) CHECK_FALSE(rollout.generate_next_window().features.empty());
  const double pool = ardy::generation_cpu_seconds() - before;
  const double caller = ardy::thread_cpu_seconds() - caller_before;
  // The pool thread shares the graphs' large operators with the caller.
  CHECK(pool > 0.1 * caller);
  CHECK(pool < 2.0 * caller);
}
