// ardy-bench: timings of the C++ runtime on one model package, as markdown
// tables (and a JSON file for bench/report.py):
//   - the peak: the rate ONNX Runtime's matrix product reaches here (a
//     1024 x 1024 MatMul probe graph, --probe), the limit the windows'
//     GFLOP/s are compared with;
//   - one window (DDIM with every guidance row, decoding, features, FK) at 4
//     steps for three cases: text only (2 rows, no goals), waypoints (3 rows,
//     sparse root waypoints every 3 s), full (a dense path: 3 rows, H and F at
//     the model's maximum); p50 and p99, the DDIM part alone, its FLOPs (the
//     matrix products of the graphs, 2 per multiply-add, counted from the
//     package's sizes), the GFLOP/s reached and the FLOPs format version 1's
//     layout (one call per step, history and goals recomputed) would do;
//   - the full case at 10 steps, and batches of 2, 4 and 8 full windows
//     (several characters) in one call, per window;
//   - one history, one goals and one denoiser call, one decoder call;
//   - text encoding, cold (cache cleared) and cached;
//   - the planner's cost on the caller's thread: advance(), sample_current(),
//     a command, measured per call while the worker generates in the
//     background (a 60 Hz loop in real time);
//   - crowds of 8, 16 and 50 planners sharing one WindowBatcher, played in
//     real time at 60 Hz: underrun seconds, windows, CPU cores used;
//   - peak resident memory.
// Not a test: nothing is asserted.
//
//   ardy-bench --package DIR [--threads N] [--repeats N] [--json FILE] [--probe FILE]
//              [--planner-seconds S] [--crowd-seconds S] [--crowds 8,16,50] [--label TEXT]
//              [--spin] [--shared-pool] [--future-tokens N]
// --shared-pool gives every graph one intra-op pool (EnvironmentOptions)
// instead of one per graph.
// --spin lets ONNX Runtime's idle intra-op threads spin (the runtime's
// default is off, so a waiting pool leaves the game's threads alone).

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "constraints.hpp"
#include "window_batcher.hpp"
#include "onnx_session.hpp"
#include "package.hpp"
#include "planner.hpp"
#include "rollout.hpp"
#include "sampler.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct Summary {
  double p50 = 0.0;
  double p99 = 0.0;
  double mean = 0.0;
  double max = 0.0;
  size_t count = 0;
};

Summary summarize(std::vector<double> v) {
  Summary s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.count = v.size();
  s.p50 = v[(v.size() - 1) / 2];
  s.p99 = v[static_cast<size_t>(std::ceil(0.99 * static_cast<double>(v.size()))) - 1];
  s.max = v.back();
  double sum = 0.0;
  for (double x : v) sum += x;
  s.mean = sum / static_cast<double>(v.size());
  return s;
}

nlohmann::json to_json(const Summary& s) {
  return {{"p50", s.p50}, {"p99", s.p99}, {"mean", s.mean}, {"max", s.max}, {"count", s.count}};
}

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

// User + system CPU seconds of the whole process so far.
double process_cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return double(t.tv_sec) + double(t.tv_usec) * 1e-6; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double current_rss_mb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  }
  return 0.0;
}

struct Args {
  std::string package;
  int threads = 0;
  int repeats = 30;
  std::string json;
  std::string probe;
  double planner_seconds = 5.0;
  double crowd_seconds = 10.0;
  std::vector<size_t> crowds{8, 16, 50};
  std::string label;
  bool spin = false;
  bool shared_pool = false;
  int future_tokens = -1;  // -1: the package's maximum (the planner's default)
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "ardy-bench: " << k << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (k == "--package") {
      a.package = value();
    } else if (k == "--threads") {
      a.threads = std::stoi(value());
    } else if (k == "--repeats") {
      a.repeats = std::max(3, std::stoi(value()));
    } else if (k == "--json") {
      a.json = value();
    } else if (k == "--probe") {
      a.probe = value();
    } else if (k == "--planner-seconds") {
      a.planner_seconds = std::stod(value());
    } else if (k == "--crowd-seconds") {
      a.crowd_seconds = std::stod(value());
    } else if (k == "--crowds") {
      a.crowds.clear();
      std::stringstream list(value());
      for (std::string item; std::getline(list, item, ',');) {
        if (!item.empty()) a.crowds.push_back(static_cast<size_t>(std::stoul(item)));
      }
    } else if (k == "--label") {
      a.label = value();
    } else if (k == "--future-tokens") {
      a.future_tokens = std::stoi(value());
    } else if (k == "--spin") {
      a.spin = true;
    } else if (k == "--shared-pool") {
      a.shared_pool = true;
    } else {
      std::cerr << "usage: ardy-bench --package DIR [--threads N] [--repeats N] [--json FILE] [--probe FILE] "
                   "[--planner-seconds S] [--crowd-seconds S] [--crowds 8,16,50] [--label TEXT] [--spin] "
                   "[--shared-pool] [--future-tokens N]\n";
      std::exit(k == "--help" || k == "-h" ? 0 : 2);
    }
  }
  if (a.package.empty()) {
    std::cerr << "ardy-bench: --package DIR is required\n";
    std::exit(2);
  }
  return a;
}

constexpr const char* kPrompt = "a person walks forward and waves with the right hand";

// --- cases ----------------------------------------------------------------------------

enum class CaseKind { text, waypoints, full };

struct BenchCase {
  CaseKind kind;
  const char* key;   // JSON key
  const char* name;  // table row
};

const BenchCase kCases[] = {
    {CaseKind::text, "text", "text only (no goals)"},
    {CaseKind::waypoints, "waypoints", "waypoints every 3 s"},
    {CaseKind::full, "full", "full (dense path)"},
};

ardy::RolloutSettings bench_settings(CaseKind kind, size_t steps, int future_tokens) {
  ardy::RolloutSettings settings;
  settings.steps = steps;
  if (future_tokens >= 0) settings.future_tokens = static_cast<size_t>(future_tokens);
  // Sparse targets stay sparse (the package may turn them into paths).
  if (kind == CaseKind::waypoints) settings.interpolate_root = false;
  return settings;
}

// A rollout of the case with a full history: a prompt, and no goals (text),
// a waypoint every 3 s along a line (waypoints) or a long dense path (full:
// every window has goals in it and beyond it).
ardy::Rollout warm_rollout(const std::shared_ptr<const ardy::ModelPackage>& package, CaseKind kind,
                           int future_tokens) {
  ardy::Rollout rollout(package, bench_settings(kind, 4, future_tokens));
  rollout.add_prompt(0, std::string(kPrompt));
  const double fps = package->fps();
  if (kind == CaseKind::full) {
    rollout.constraints().add(ardy::path_from_polyline({{0.0, 0.0}, {0.0, 400.0}}, 1.2, 0, fps));
  } else if (kind == CaseKind::waypoints) {
    const auto every = static_cast<int64_t>(3.0 * fps);
    for (int64_t frame = every; frame < static_cast<int64_t>(400.0 * fps); frame += every) {
      ardy::RootWaypoint waypoint;
      waypoint.frame = frame;
      waypoint.z = 1.2 * static_cast<double>(frame) / fps;
      rollout.constraints().add(waypoint);
    }
  }
  const size_t max_history = package->tokens().max_history;
  while (rollout.stored_tokens() < max_history) rollout.generate_next_window();
  return rollout;
}

// --- FLOPs -------------------------------------------------------------------------------
// The matrix products of the graphs (2 FLOPs per multiply-add), from the
// package's sizes; layer norms, softmax and element-wise work are left out
// (a few percent).

// `layers` transformer layers over `queries` computed tokens that attend to
// `keys` keys.
double transformer_flops(const ardy::DenoiserSizes& s, size_t layers, double queries, double keys) {
  const double w = static_cast<double>(s.width), ff = w * static_cast<double>(s.ff_mult);
  const double per_token = 2.0 * (3.0 * w * w + w * w + 2.0 * w * ff);
  const double attention = 2.0 * 2.0 * queries * keys * w;  // scores and the weighted sum
  return static_cast<double>(layers) * (queries * per_token + attention);
}

// The goals' share of the input projections of one window (all stages): the
// window goals beside each window token and the `future` tokens.
double goal_projection_flops(const ardy::ModelPackage& p, size_t future) {
  const ardy::DenoiserSizes& s = p.denoiser_sizes();
  const ardy::TokenSizes& t = p.tokens();
  const double w = static_cast<double>(s.width), c = static_cast<double>(t.window);
  const double pm = static_cast<double>(t.goal_dim), f = static_cast<double>(future);
  const double per_stage = 2.0 * w * (c * (static_cast<double>(s.window_goal_dim) + pm) + f * 2.0 * pm);
  return static_cast<double>(s.stages()) * per_stage;
}

// One denoiser row (both stages) for one step: step, text, window and `future`
// tokens computed, attending to `history` keys as well. `uncached`: format
// version 1's layout, where the call also computes the history tokens and the
// goals' projections.
double denoiser_row_flops(const ardy::ModelPackage& p, size_t history, size_t future, bool uncached) {
  const ardy::DenoiserSizes& s = p.denoiser_sizes();
  const ardy::TokenSizes& t = p.tokens();
  const double w = static_cast<double>(s.width), c = static_cast<double>(t.window);
  const double h = static_cast<double>(history), f = static_cast<double>(future);
  const double d = static_cast<double>(t.token_dim);
  const double queries = 2.0 + c + f + (uncached ? h : 0.0);
  double per_stage = transformer_flops(s, s.layers, queries, queries + (uncached ? 0.0 : h));
  per_stage += 2.0 * w * (c * d + static_cast<double>(p.text_embedding_size()));  // tokens, text
  // The modulation: one projection of the row's condition to 6 vectors per layer.
  if (s.condition_modulation) per_stage += 2.0 * w * 6.0 * static_cast<double>(s.layers) * w;
  if (uncached) per_stage += 2.0 * w * h * d;
  double flops = static_cast<double>(s.stages()) * per_stage + 2.0 * c * w * d;  // + the heads (root and latent)
  if (uncached) flops += goal_projection_flops(p, future);
  return flops;
}

// The history graph for one window.
double history_flops(const ardy::ModelPackage& p, size_t history) {
  if (history == 0) return 0.0;
  const ardy::DenoiserSizes& s = p.denoiser_sizes();
  const double w = static_cast<double>(s.width), h = static_cast<double>(history);
  const double d = static_cast<double>(p.tokens().token_dim);
  // Every layer but the last runs whole; the last only projects keys and values.
  const double per_stage = 2.0 * h * d * w + transformer_flops(s, s.layers - 1, h, h) + 2.0 * h * w * 3.0 * w;
  return static_cast<double>(s.stages()) * per_stage;
}

struct WindowWork {
  double flops = 0.0;           // what the runtime does: history and goals once, the row groups every step
  double uncached_flops = 0.0;  // one call per step with every row computing history and F future tokens
  size_t rows = 0;
  size_t history = 0;
  size_t future = 0;           // F of the constraint row
  size_t future_attended = 0;  // future tokens with a goal
};

WindowWork window_work(const ardy::ModelPackage& p, const ardy::WindowInput& in) {
  WindowWork work;
  const std::vector<ardy::GuidanceRow> rows =
      ardy::guidance_rows(in.w_text, in.w_con, in.text_embedding.has_value(), in.goals.has_constraints());
  work.rows = rows.size();
  work.history = in.history_tokens;
  work.future = in.goals.future_tokens;
  for (float v : in.goals.future_mask) work.future_attended += v != 0.0f ? 1 : 0;
  const double steps = static_cast<double>(in.steps);
  work.flops = history_flops(p, in.history_tokens);
  const bool constraint_row =
      std::any_of(rows.begin(), rows.end(), [](const ardy::GuidanceRow& row) { return row.constraint_keep != 0.0f; });
  if (constraint_row) work.flops += goal_projection_flops(p, in.goals.future_tokens);
  for (const ardy::GuidanceRow& row : rows) {
    const size_t future = row.constraint_keep != 0.0f ? in.goals.future_tokens : 0;
    work.flops += steps * denoiser_row_flops(p, in.history_tokens, future, false);
    work.uncached_flops += steps * denoiser_row_flops(p, in.history_tokens, in.goals.future_tokens, true);
  }
  return work;
}

// --- timing ------------------------------------------------------------------------------------

struct CaseTimes {
  std::vector<double> window_ms, ddim_ms, prepare_ms;
  WindowWork work;
};

// `repeats` windows of the rollout at `steps`: generate_window (the model,
// committed), sample_windows alone on the same input (the DDIM part), and
// prepare_window (history, goals, cached text).
CaseTimes time_case(ardy::Rollout& rollout, CaseKind kind, size_t steps, int future_tokens, int repeats) {
  rollout.configure(bench_settings(kind, steps, future_tokens));
  CaseTimes times;
  for (int i = -2; i < repeats; ++i) {  // two warm-up windows
    auto t0 = Clock::now();
    const ardy::WindowInput in = rollout.prepare_window();
    const double prep = seconds_since(t0) * 1e3;
    const std::vector<float> noise = rollout.draw_noise();
    t0 = Clock::now();
    ardy::sample_windows(rollout.package(), {&in}, {&noise});
    const double ddim = seconds_since(t0) * 1e3;
    t0 = Clock::now();
    const ardy::WindowResult out = ardy::generate_window(rollout.package(), in, noise);
    const double ms = seconds_since(t0) * 1e3;
    rollout.commit(out, rollout.package().tokens().window);
    times.work = window_work(rollout.package(), in);
    if (i >= 0) {
      times.window_ms.push_back(ms);
      times.ddim_ms.push_back(ddim);
      times.prepare_ms.push_back(prep);
    }
  }
  return times;
}

// Times one batch of `count` windows (copies of one window, the characters of
// a scene) in one generate_windows call: one history call, the row groups of
// every window in one denoiser call per step, one decoder call per window.
std::vector<double> time_batch(ardy::Rollout& rollout, size_t count, int repeats) {
  const ardy::WindowInput in = rollout.prepare_window();
  const std::vector<float> noise = rollout.draw_noise();
  const std::vector<const ardy::WindowInput*> inputs(count, &in);
  const std::vector<const std::vector<float>*> noises(count, &noise);
  std::vector<double> ms;
  for (int i = -1; i < repeats; ++i) {
    const auto t0 = Clock::now();
    ardy::generate_windows(rollout.package(), inputs, noises);
    if (i >= 0) ms.push_back(seconds_since(t0) * 1e3);
  }
  return ms;
}

// The history graph's inputs for one window's history [1, H, D].
std::vector<std::pair<std::string, ardy::Tensor>> history_inputs(const ardy::ModelPackage& p,
                                                                 const ardy::WindowInput& in) {
  const auto h = static_cast<int64_t>(in.history_tokens), d = static_cast<int64_t>(p.tokens().token_dim);
  std::vector<std::pair<std::string, ardy::Tensor>> x;
  x.emplace_back("history", ardy::Tensor::float32({1, h, d}, in.history));
  x.emplace_back("history_mask", ardy::Tensor::float32({1, h}, std::vector<float>(in.history_tokens, 1.0f)));
  return x;
}

// The goals graph's inputs for one window's goals [1, ...].
std::vector<std::pair<std::string, ardy::Tensor>> goals_inputs(const ardy::ModelPackage& p,
                                                               const ardy::WindowInput& in) {
  const ardy::TokenSizes& t = p.tokens();
  const auto c = static_cast<int64_t>(t.window), g = static_cast<int64_t>(t.goal_dim);
  const auto f = static_cast<int64_t>(in.goals.future_tokens);
  std::vector<std::pair<std::string, ardy::Tensor>> x;
  x.emplace_back("window_goal", ardy::Tensor::float32({1, c, g}, in.goals.window_goal));
  x.emplace_back("window_goal_mask", ardy::Tensor::float32({1, c, g}, in.goals.window_goal_mask));
  x.emplace_back("future_goal", ardy::Tensor::float32({1, f, g}, in.goals.future_goal));
  x.emplace_back("future_goal_mask", ardy::Tensor::float32({1, f, g}, in.goals.future_goal_mask));
  return x;
}

// The denoiser inputs of a window's constraint row (D_con, the one with the
// future tokens): its history keys and values and its goals graph outputs.
std::vector<std::pair<std::string, ardy::Tensor>> denoiser_inputs(const ardy::ModelPackage& p,
                                                                  const ardy::WindowInput& in,
                                                                  const ardy::Tensor& history_kv,
                                                                  const std::vector<ardy::Tensor>& goals) {
  const ardy::TokenSizes& t = p.tokens();
  const auto c = static_cast<int64_t>(t.window), d = static_cast<int64_t>(t.token_dim);
  const auto h = static_cast<int64_t>(in.history_tokens), f = static_cast<int64_t>(in.goals.future_tokens);
  const auto e = static_cast<int64_t>(p.text_embedding_size());
  std::vector<std::pair<std::string, ardy::Tensor>> x;
  x.emplace_back("x_t", ardy::Tensor::float32({1, c, d}, std::vector<float>(t.window * t.token_dim, 0.5f)));
  x.emplace_back("step", ardy::Tensor::int64({1}, {9}));
  x.emplace_back("text_embedding",
                 ardy::Tensor::float32({1, e}, in.text_embedding.value_or(std::vector<float>(size_t(e), 0.0f))));
  x.emplace_back("text_keep", ardy::Tensor::float32({1}, {0.0f}));
  x.emplace_back("history_kv", history_kv);
  x.emplace_back("history_mask", ardy::Tensor::float32({1, h}, std::vector<float>(in.history_tokens, 1.0f)));
  for (size_t i = 0; i < goals.size(); ++i) x.emplace_back(p.goals().outputs()[i].name, goals[i]);
  x.emplace_back("future_mask", ardy::Tensor::float32({1, f}, in.goals.future_mask));
  x.emplace_back("constraint_keep", ardy::Tensor::float32({1}, {1.0f}));
  return x;
}

// Best-of-`repeats` rate of the probe graph (c = a @ b, [N, N]) in GFLOP/s,
// on every core: the machine's limit, whatever threads the windows use (with
// one intra-op thread the sampler still runs two graph calls at once).
double probe_gflops(const ardy::ModelPackage& p, const std::string& file, ardy::SessionOptions options,
                    size_t& size) {
  options.intra_op_threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const ardy::OnnxSession probe = ardy::OnnxSession::from_file(p.environment(), file, options);
  size = static_cast<size_t>(probe.inputs().at(0).shape.at(0));
  const auto n = static_cast<int64_t>(size);
  std::vector<std::pair<std::string, ardy::Tensor>> inputs;
  inputs.emplace_back("a", ardy::Tensor::float32({n, n}, std::vector<float>(size * size, 0.5f)));
  double best = 1e9;
  for (int i = -2; i < 20; ++i) {
    const auto t0 = Clock::now();
    probe.run(inputs, {"c"});
    if (i >= 0) best = std::min(best, seconds_since(t0));
  }
  return 2.0 * std::pow(static_cast<double>(size), 3.0) / best / 1e9;
}

// --- crowds ------------------------------------------------------------------------------------

struct CrowdResult {
  size_t planners = 0;
  double seconds = 0.0;
  uint64_t windows = 0;
  uint64_t late = 0;
  double underrun_total = 0.0;  // summed over planners
  double underrun_max = 0.0;    // the worst planner
  double cores = 0.0;           // process CPU while it played
  size_t largest_batch = 0;
  Summary frame_us;             // the caller's thread: advance + sample of every planner
};

// `count` planners sharing one WindowBatcher, each with its own prompt, seed
// and start, played in real time at 60 Hz for `seconds` after they all have
// their first window; every 2 s a quarter of them gets a new prompt.
CrowdResult run_crowd(const std::shared_ptr<const ardy::ModelPackage>& package, size_t count, double seconds) {
  const char* prompts[] = {"a person walks forward", "a person runs forward", kPrompt, "a person walks in a circle"};
  ardy::WindowBatcher batcher;
  std::vector<std::unique_ptr<ardy::Planner>> planners;
  for (size_t i = 0; i < count; ++i) {
    ardy::PlannerConfig config;
    config.generator = batcher.generator();
    config.seed = i + 1;
    config.prompt = prompts[i % 4];
    config.start_xz = {2.0 * static_cast<double>(i % 10), 2.0 * static_cast<double>(i / 10)};
    planners.push_back(std::make_unique<ardy::Planner>(package, config));
  }
  for (auto& planner : planners) planner->wait_idle(120.0);
  std::vector<ardy::PlannerStats> before;
  for (auto& planner : planners) before.push_back(planner->stats());
  ardy::Pose pose;
  std::vector<double> frame_us;
  const double dt = 1.0 / 60.0;
  const int frames = static_cast<int>(seconds / dt);
  const double cpu0 = process_cpu_seconds();
  const auto wall0 = Clock::now();
  auto next = Clock::now();
  for (int f = 0; f < frames; ++f) {
    if (f > 0 && f % 120 == 0) {
      const size_t quarter = static_cast<size_t>(f / 120) % 4;
      for (size_t i = quarter; i < count; i += 4) planners[i]->set_prompt(prompts[(i + static_cast<size_t>(f)) % 4]);
    }
    const auto t0 = Clock::now();
    for (auto& planner : planners) {
      planner->advance(dt);
      planner->sample_current(pose);
    }
    frame_us.push_back(seconds_since(t0) * 1e6);
    next += std::chrono::microseconds(16667);
    std::this_thread::sleep_until(next);
  }
  CrowdResult result;
  result.planners = count;
  result.seconds = seconds_since(wall0);
  result.cores = (process_cpu_seconds() - cpu0) / result.seconds;
  for (size_t i = 0; i < count; ++i) {
    const ardy::PlannerStats after = planners[i]->stats();
    result.windows += after.windows_published - before[i].windows_published;
    result.late += after.late_windows - before[i].late_windows;
    const double underrun = after.underrun_seconds - before[i].underrun_seconds;
    result.underrun_total += underrun;
    result.underrun_max = std::max(result.underrun_max, underrun);
  }
  result.largest_batch = batcher.stats().largest_batch;
  result.frame_us = summarize(frame_us);
  return result;
}

std::string fmt(double v, int digits = 2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  try {
    const double rss_start = current_rss_mb();
    ardy::PackageOptions options;
    options.session.intra_op_threads = args.threads;
    options.session.allow_spinning = args.spin;
    options.shared_thread_pool = args.shared_pool;
    const int threads = ardy::effective_intra_op_threads(args.threads);
    auto t0 = Clock::now();
    auto package = std::make_shared<const ardy::ModelPackage>(ardy::ModelPackage::from_folder(args.package, options));
    const double load_s = seconds_since(t0);
    const double rss_loaded = current_rss_mb();
    const ardy::ModelPackage& p = *package;
    const ardy::TokenSizes& t = p.tokens();

    // --- peak ----------------------------------------------------------------------
    double peak_gflops = 0.0;
    size_t probe_size = 0;
    if (!args.probe.empty()) peak_gflops = probe_gflops(p, args.probe, options.session, probe_size);

    // --- text --------------------------------------------------------------------
    std::vector<double> text_cold, text_cached;
    for (int i = 0; i < args.repeats; ++i) {
      p.text_encoder().clear_cache();
      t0 = Clock::now();
      p.text_encoder().encode(kPrompt);
      text_cold.push_back(seconds_since(t0) * 1e6);
    }
    for (int i = 0; i < args.repeats * 100; ++i) {
      t0 = Clock::now();
      p.text_encoder().encode(kPrompt);
      text_cached.push_back(seconds_since(t0) * 1e6);
    }

    // --- windows --------------------------------------------------------------------
    std::vector<CaseTimes> cases;
    for (const BenchCase& bench_case : kCases) {
      ardy::Rollout rollout = warm_rollout(package, bench_case.kind, args.future_tokens);
      cases.push_back(time_case(rollout, bench_case.kind, 4, args.future_tokens, args.repeats));
    }
    ardy::Rollout rollout = warm_rollout(package, CaseKind::full, args.future_tokens);
    const CaseTimes full10 = time_case(rollout, CaseKind::full, 10, args.future_tokens, std::max(3, args.repeats / 2));
    rollout.configure(bench_settings(CaseKind::full, 4, args.future_tokens));
    const std::vector<size_t> batch_sizes{1, 2, 4, 8};
    std::vector<Summary> batches;
    for (size_t n : batch_sizes) batches.push_back(summarize(time_batch(rollout, n, std::max(3, args.repeats / 2))));

    // --- single graph calls ------------------------------------------------------------
    const ardy::WindowInput in = rollout.prepare_window();
    const auto history_in = history_inputs(p, in);
    std::vector<double> history_ms;
    for (int i = -2; i < args.repeats * 2; ++i) {
      t0 = Clock::now();
      p.history().run(history_in, {"history_kv"});
      if (i >= 0) history_ms.push_back(seconds_since(t0) * 1e3);
    }
    const auto goals_in = goals_inputs(p, in);
    std::vector<double> goals_ms;
    for (int i = -2; i < args.repeats * 2; ++i) {
      t0 = Clock::now();
      p.goals().run(goals_in, {});
      if (i >= 0) goals_ms.push_back(seconds_since(t0) * 1e3);
    }
    const auto inputs =
        denoiser_inputs(p, in, p.history().run(history_in, {"history_kv"}).at(0), p.goals().run(goals_in, {}));
    std::vector<double> denoiser_ms;
    for (int i = -2; i < args.repeats * 2; ++i) {
      t0 = Clock::now();
      p.denoiser().run(inputs, {"x0"});
      if (i >= 0) denoiser_ms.push_back(seconds_since(t0) * 1e3);
    }
    const size_t k = std::min(in.history_tokens, in.decode_context_tokens);
    std::vector<float> tokens(in.history.end() - static_cast<std::ptrdiff_t>(k * t.token_dim), in.history.end());
    tokens.resize((k + t.window) * t.token_dim, 0.1f);
    std::vector<std::pair<std::string, ardy::Tensor>> dec;
    const std::vector<int64_t> tokens_shape{1, static_cast<int64_t>(k + t.window), static_cast<int64_t>(t.token_dim)};
    dec.emplace_back("tokens", ardy::Tensor::float32(tokens_shape, tokens));
    dec.emplace_back("prev_root", ardy::Tensor::float32({1, 5}, std::vector<float>(5, 0.0f)));
    dec.emplace_back("prev_root_valid", ardy::Tensor::float32({1}, {0.0f}));
    std::vector<double> decoder_ms;
    for (int i = -2; i < args.repeats * 2; ++i) {
      t0 = Clock::now();
      p.decoder().run(dec, {"body"});
      if (i >= 0) decoder_ms.push_back(seconds_since(t0) * 1e3);
    }

    // --- planner on the caller's thread ---------------------------------------------------
    std::vector<double> advance_us, sample_us, frame_us, command_us, sample_hot_us;
    ardy::PlannerStats pstats;
    double planner_cores = 0.0;  // CPU used by the process while the planner streamed, in cores
    {
      ardy::PlannerConfig config;
      ardy::Planner planner(package, config);
      planner.set_prompt(kPrompt);
      planner.wait_idle(60.0);
      ardy::Pose pose;
      planner.sample_current(pose);  // sizes the pose once
      const double dt = 1.0 / 60.0;
      const int frames = static_cast<int>(args.planner_seconds / dt);
      auto next = Clock::now();
      const char* prompts[] = {"a person runs forward", "a person walks in a circle", kPrompt};
      const double cpu0 = process_cpu_seconds();
      const auto wall0 = Clock::now();
      for (int i = 0; i < frames; ++i) {
        if (i > 0 && i % 60 == 0) {  // a command every second
          t0 = Clock::now();
          if ((i / 60) % 2) {
            planner.set_prompt(prompts[(i / 60) % 3]);
          } else {
            planner.add_waypoint(planner.time() + 2.0, 0.5 * i / 60.0, 1.0);
          }
          command_us.push_back(seconds_since(t0) * 1e6);
        }
        const auto f0 = Clock::now();
        planner.advance(dt);
        const auto f1 = Clock::now();
        planner.sample_current(pose);
        const auto f2 = Clock::now();
        advance_us.push_back(std::chrono::duration<double>(f1 - f0).count() * 1e6);
        sample_us.push_back(std::chrono::duration<double>(f2 - f1).count() * 1e6);
        frame_us.push_back(std::chrono::duration<double>(f2 - f0).count() * 1e6);
        next += std::chrono::microseconds(16667);
        std::this_thread::sleep_until(next);
      }
      planner_cores = (process_cpu_seconds() - cpu0) / seconds_since(wall0);
      pstats = planner.stats();
      // The same call in a hot loop (warm caches), averaged over chunks of 100 calls.
      planner.wait_idle(60.0);
      const double now = planner.time();
      for (int chunk = 0; chunk < 200; ++chunk) {
        t0 = Clock::now();
        for (int i = 0; i < 100; ++i) planner.sample(now - 0.001 * i, pose);
        sample_hot_us.push_back(seconds_since(t0) * 1e6 / 100.0);
      }
    }
    // --- crowds ----------------------------------------------------------------------------
    std::vector<CrowdResult> crowds;
    for (size_t count : args.crowds) crowds.push_back(run_crowd(package, count, args.crowd_seconds));
    const double rss_peak = peak_rss_mb();

    // --- report --------------------------------------------------------------------------
    const Summary s10 = summarize(full10.window_ms);
    const Summary shist = summarize(history_ms), sgoals = summarize(goals_ms);
    const Summary sd = summarize(denoiser_ms), sdec = summarize(decoder_ms);
    const Summary stc = summarize(text_cold), stw = summarize(text_cached);
    const Summary sadv = summarize(advance_us), ssam = summarize(sample_us), sfr = summarize(frame_us);
    const Summary scmd = summarize(command_us), shot = summarize(sample_hot_us);
    const std::string label = args.label.empty() ? args.package : args.label;
    const std::string text_model = p.text_settings().graph_file + ", " + std::to_string(p.text_embedding_size()) + "-d";
    const ardy::DenoiserSizes& sizes = p.denoiser_sizes();

    std::ostringstream o;
    o << "### C++ runtime (ONNX Runtime " << ardy::OnnxEnvironment::runtime_version() << ", " << threads
      << " intra-op thread" << (threads == 1 ? "" : "s") << (args.spin ? " (spinning)" : "")
      << (args.shared_pool ? ", one pool shared by every graph" : "") << ", "
      << std::thread::hardware_concurrency() << " cores)\n\n";
    o << "Model: " << label << " (C = " << t.window << " tokens = " << t.window_frames() << " frames, L = "
      << t.latent_dim << "; denoiser " << sizes.stages() << " x " << sizes.layers << " layers, width " << sizes.width
      << "); load " << fmt(load_s, 2) << " s.";
    if (peak_gflops > 0.0) {
      o << " Peak: a " << probe_size << " x " << probe_size << " MatMul reaches " << fmt(peak_gflops, 1)
        << " GFLOP/s here on every core.";
    }
    o << "\n\n";
    o << "| window, 4 steps | rows | H | F (with goals) | p50 | p99 | DDIM p50 | DDIM GFLOP | GFLOP/s | of peak | "
         "uncached GFLOP |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (size_t i = 0; i < cases.size(); ++i) {
      const CaseTimes& c = cases[i];
      const Summary sw = summarize(c.window_ms), sddim = summarize(c.ddim_ms);
      const double gflop = c.work.flops / 1e9;
      const double rate = gflop / (sddim.p50 / 1e3);
      o << "| " << kCases[i].name << " | " << c.work.rows << " | " << c.work.history << " | " << c.work.future << " ("
        << c.work.future_attended << ") | " << fmt(sw.p50) << " ms | " << fmt(sw.p99) << " ms | " << fmt(sddim.p50)
        << " ms | " << fmt(gflop, 3) << " | " << fmt(rate, 1) << " | "
        << (peak_gflops > 0.0 ? fmt(100.0 * rate / peak_gflops, 0) + " %" : std::string("-")) << " | "
        << fmt(c.work.uncached_flops / 1e9, 3) << " |\n";
    }
    o << "\n| measurement | p50 | p99 | n |\n|---|---|---|---|\n";
    for (size_t i = 1; i < batch_sizes.size(); ++i) {
      const Summary& b = batches[i];
      o << "| batch of " << batch_sizes[i] << " full windows (characters), 4 steps, one call: per window | "
        << fmt(b.p50 / double(batch_sizes[i])) << " ms | " << fmt(b.p99 / double(batch_sizes[i])) << " ms | " << b.count
        << " |\n";
    }
    o << "| full window, 10 steps | " << fmt(s10.p50) << " ms | " << fmt(s10.p99) << " ms | " << s10.count << " |\n";
    const Summary sp4 = summarize(cases.back().prepare_ms);
    o << "| window preparation (history, goals, cached text) | " << fmt(sp4.p50, 3) << " ms | " << fmt(sp4.p99, 3)
      << " ms | " << sp4.count << " |\n";
    o << "| history call, H = " << in.history_tokens << " | " << fmt(shist.p50) << " ms | " << fmt(shist.p99)
      << " ms | " << shist.count << " |\n";
    o << "| goals call, F = " << in.goals.future_tokens << " | " << fmt(sgoals.p50) << " ms | " << fmt(sgoals.p99)
      << " ms | " << sgoals.count << " |\n";
    o << "| denoiser call, constraint row (F = " << in.goals.future_tokens << ") | " << fmt(sd.p50) << " ms | "
      << fmt(sd.p99) << " ms | " << sd.count << " |\n";
    o << "| decoder call, " << (k + t.window) << " tokens | " << fmt(sdec.p50) << " ms | " << fmt(sdec.p99) << " ms | "
      << sdec.count << " |\n";
    o << "| text encoding, cold (" << text_model << ") | " << fmt(stc.p50 / 1e3) << " ms | " << fmt(stc.p99 / 1e3)
      << " ms | " << stc.count << " |\n";
    o << "| text encoding, cached | " << fmt(stw.p50) << " us | " << fmt(stw.p99) << " us | " << stw.count << " |\n";
    o << "| planner advance() (caller's thread) | " << fmt(sadv.p50, 3) << " us | " << fmt(sadv.p99, 3) << " us | "
      << sadv.count << " |\n";
    o << "| planner sample_current() (21 joints) | " << fmt(ssam.p50, 3) << " us | " << fmt(ssam.p99, 3) << " us | "
      << ssam.count << " |\n";
    o << "| planner sample(), hot loop | " << fmt(shot.p50, 3) << " us | " << fmt(shot.p99, 3) << " us | "
      << shot.count * 100 << " |\n";
    o << "| planner frame (advance + sample), 60 Hz, worker running | " << fmt(sfr.p50, 3) << " us | "
      << fmt(sfr.p99, 3) << " us (max " << fmt(sfr.max, 1) << ") | " << sfr.count << " |\n";
    o << "| planner command (set_prompt / add_waypoint) | " << fmt(scmd.p50, 2) << " us | " << fmt(scmd.p99, 2)
      << " us | " << scmd.count << " |\n\n";
    if (!crowds.empty()) {
      o << "| crowd, one WindowBatcher, real time | seconds | windows | late | underrun (sum / worst planner) | "
           "largest batch | CPU cores | caller's thread per frame p50 / p99 |\n|---|---|---|---|---|---|---|---|\n";
      for (const CrowdResult& c : crowds) {
        o << "| " << c.planners << " planners | " << fmt(c.seconds, 1) << " | " << c.windows << " | " << c.late << " | "
          << fmt(c.underrun_total, 3) << " s / " << fmt(c.underrun_max, 3) << " s | " << c.largest_batch << " | "
          << fmt(c.cores, 2) << " | " << fmt(c.frame_us.p50, 1) << " / " << fmt(c.frame_us.p99, 1) << " us |\n";
      }
      o << "\n";
    }
    o << "Memory: RSS " << fmt(rss_start, 0) << " MB at start, " << fmt(rss_loaded, 0) << " MB with the package loaded, peak "
      << fmt(rss_peak, 0) << " MB. Planner run: " << pstats.windows_published << " windows, " << pstats.splices
      << " splices, " << pstats.late_windows << " late, measured window latency " << fmt(pstats.last_latency_seconds * 1e3, 1)
      << " ms, replan buffer B = " << pstats.buffer_frames << " frames, underrun " << fmt(pstats.underrun_seconds, 3)
      << " s; the process used " << fmt(planner_cores, 2) << " cores of CPU while it streamed (commands every second).\n";
    std::cout << o.str();

    if (!args.json.empty()) {
      nlohmann::json j;
      j["label"] = label;
      j["package"] = args.package;
      j["threads"] = threads;
      j["spinning"] = args.spin;
      j["shared_pool"] = args.shared_pool;
      j["cores"] = std::thread::hardware_concurrency();
      j["onnxruntime"] = ardy::OnnxEnvironment::runtime_version();
      j["peak_gflops"] = peak_gflops;
      j["probe_size"] = probe_size;
      j["window_tokens"] = t.window;
      j["denoiser"] = {{"stages", sizes.stages()}, {"layers", sizes.layers}, {"width", sizes.width}};
      for (size_t i = 0; i < cases.size(); ++i) {
        const CaseTimes& c = cases[i];
        j["cases"][kCases[i].key] = {{"name", kCases[i].name},
                                     {"rows", c.work.rows},
                                     {"history_tokens", c.work.history},
                                     {"future_tokens", c.work.future},
                                     {"future_attended", c.work.future_attended},
                                     {"window_4_ms", to_json(summarize(c.window_ms))},
                                     {"ddim_4_ms", to_json(summarize(c.ddim_ms))},
                                     {"flops", c.work.flops},
                                     {"uncached_flops", c.work.uncached_flops}};
      }
      j["text_model"] = text_model;
      j["load_seconds"] = load_s;
      j["window_10_ms"] = to_json(s10);
      for (size_t i = 0; i < batch_sizes.size(); ++i) {
        j["batch_window_4_ms"][std::to_string(batch_sizes[i])] = to_json(batches[i]);
      }
      j["prepare_ms"] = to_json(sp4);
      j["history_call_ms"] = to_json(shist);
      j["goals_call_ms"] = to_json(sgoals);
      j["denoiser_call_ms"] = to_json(sd);
      j["decoder_call_ms"] = to_json(sdec);
      j["text_cold_us"] = to_json(stc);
      j["text_cached_us"] = to_json(stw);
      j["advance_us"] = to_json(sadv);
      j["sample_us"] = to_json(ssam);
      j["frame_us"] = to_json(sfr);
      j["command_us"] = to_json(scmd);
      j["sample_hot_us"] = to_json(shot);
      j["rss_start_mb"] = rss_start;
      j["rss_loaded_mb"] = rss_loaded;
      j["rss_peak_mb"] = rss_peak;
      j["planner"] = {{"windows", pstats.windows_published}, {"splices", pstats.splices},
                      {"late", pstats.late_windows}, {"latency_ms", pstats.last_latency_seconds * 1e3},
                      {"buffer_frames", pstats.buffer_frames}, {"underrun_s", pstats.underrun_seconds},
                      {"cpu_cores", planner_cores}};
      for (const CrowdResult& c : crowds) {
        j["crowds"].push_back({{"planners", c.planners},
                               {"seconds", c.seconds},
                               {"windows", c.windows},
                               {"late", c.late},
                               {"underrun_total_s", c.underrun_total},
                               {"underrun_max_s", c.underrun_max},
                               {"largest_batch", c.largest_batch},
                               {"cpu_cores", c.cores},
                               {"frame_us", to_json(c.frame_us)}});
      }
      std::ofstream(args.json) << j.dump(1) << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "ardy-bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
