// WindowBatcher: several planners' windows in one denoiser call per step, on
// the tiny package. Batches are made deterministic by their size (a full
// batch starts at once) or by a long gather time; nothing here asserts a
// wall-clock time.

#include <catch_amalgamated.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <glm/geometric.hpp>

#include "planner.hpp"
#include "support/error_message.hpp"
#include "support/goldens.hpp"
#include "window_batcher.hpp"

using ardy::Planner;
using ardy::PlannerConfig;
using ardy::Pose;
using ardy::WindowBatcher;
using ardy::WindowBatcherConfig;
using ardy_test::error_message;
using ardy_test::tiny_package;
using Catch::Matchers::ContainsSubstring;

namespace {

// Planners on a fake clock (latency 0), so their windows depend only on
// their commands and seeds.
PlannerConfig planner_config(uint64_t seed, const WindowBatcher* batcher) {
  PlannerConfig c;
  c.seed = seed;
  c.clock = [] { return 0.0; };
  if (batcher) c.generator = batcher->generator();
  return c;
}

std::vector<glm::vec3> positions(const Planner& planner, int64_t frames) {
  std::vector<glm::vec3> out;
  Pose pose;
  for (int64_t f = 0; f < frames; ++f) {
    REQUIRE(planner.frame_at(f, pose));
    out.insert(out.end(), pose.positions.begin(), pose.positions.end());
  }
  return out;
}

double max_distance(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  REQUIRE(a.size() == b.size());
  double m = 0.0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, double(glm::length(a[i] - b[i])));
  return m;
}

}  // namespace

TEST_CASE("planners sharing a batcher run their windows in one batch, with the motion each makes alone",
          "[batcher][threads]") {
  WindowBatcherConfig config;
  config.gather_seconds = 10.0;  // the batch starts when it is full
  config.max_windows = 3;
  WindowBatcher batcher(config);
  std::vector<std::unique_ptr<Planner>> shared;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    shared.push_back(std::make_unique<Planner>(tiny_package(), planner_config(seed, &batcher)));
  }
  for (auto& p : shared) REQUIRE(p->wait_idle());
  auto stats = batcher.stats();
  CHECK(stats.batches == 1);
  CHECK(stats.windows == 3);
  CHECK(stats.largest_batch == 3);

  const int64_t frames = static_cast<int64_t>(tiny_package()->tokens().window_frames());
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    Planner alone(tiny_package(), planner_config(seed, nullptr));
    REQUIRE(alone.wait_idle());
    INFO("seed " << seed);
    CHECK(max_distance(positions(alone, frames), positions(*shared[seed - 1], frames)) < 1e-4);
  }

  // A prompt for everyone: the three splices run as one batch again.
  for (auto& p : shared) p->set_prompt("a person waves");
  for (auto& p : shared) REQUIRE(p->wait_idle());
  stats = batcher.stats();
  CHECK(stats.batches == 2);
  CHECK(stats.windows == 6);
  for (auto& p : shared) CHECK(p->take_errors().empty());
}

TEST_CASE("windows with different step counts run in separate batches", "[batcher]") {
  WindowBatcherConfig config;
  config.gather_seconds = 0.05;
  WindowBatcher batcher(config);
  PlannerConfig two = planner_config(1, &batcher), four = planner_config(2, &batcher);
  two.steps = 2;
  four.steps = 4;
  Planner a(tiny_package(), two), b(tiny_package(), four);
  REQUIRE(a.wait_idle());
  REQUIRE(b.wait_idle());
  const auto stats = batcher.stats();
  CHECK(stats.batches == 2);
  CHECK(stats.largest_batch == 1);
}

TEST_CASE("a planner destroyed while its window waits in the batcher does not wait for the batch",
          "[batcher][threads]") {
  WindowBatcherConfig config;
  config.gather_seconds = 10.0;
  config.max_windows = 2;
  WindowBatcher batcher(config);
  {
    Planner waiting(tiny_package(), planner_config(1, &batcher));
    // Its first window is queued, alone, for up to 10 s.
    for (int i = 0; i < 10000 && batcher.stats().queued == 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    REQUIRE(batcher.stats().queued == 1);
  }
  auto stats = batcher.stats();
  CHECK(stats.withdrawn == 1);
  CHECK(stats.batches == 0);
  // The batcher goes on: two planners fill a batch.
  Planner a(tiny_package(), planner_config(2, &batcher)), b(tiny_package(), planner_config(3, &batcher));
  REQUIRE(a.wait_idle());
  REQUIRE(b.wait_idle());
  stats = batcher.stats();
  CHECK(stats.batches == 1);
  CHECK(stats.largest_batch == 2);
  CHECK(a.take_errors().empty());
}

TEST_CASE("a planner whose batcher is gone reports its windows failed and stays usable", "[batcher][errors]") {
  auto batcher = std::make_unique<WindowBatcher>(WindowBatcherConfig{0.0, 4});
  Planner planner(tiny_package(), planner_config(1, batcher.get()));
  REQUIRE(planner.wait_idle());
  batcher.reset();
  planner.set_prompt("a person walks");
  REQUIRE(planner.wait_idle());
  const std::vector<std::string> errors = planner.take_errors();
  REQUIRE_FALSE(errors.empty());
  CHECK_THAT(errors.front(), ContainsSubstring("the window batcher is gone"));
  Pose pose;
  CHECK(planner.sample_current(pose));  // the motion made before is still there
  CHECK(planner.stats().failed_windows >= 1);
}

TEST_CASE("batcher settings are validated", "[batcher][errors]") {
  CHECK_THAT(error_message([] { WindowBatcher b(WindowBatcherConfig{-1.0, 4}); }),
             ContainsSubstring("gather_seconds is -1"));
  CHECK_THAT(error_message([] { WindowBatcher b(WindowBatcherConfig{0.0, 0}); }),
             ContainsSubstring("max_windows is 0"));
}
