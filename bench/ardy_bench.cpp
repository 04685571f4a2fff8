// ardy-bench: timings of the C++ runtime on one model package, as markdown
// tables (and a JSON file for bench/report.py):
//   - one window (DDIM with every guidance row, decoding, features, FK) at 4
//     and 10 steps, with a full history and a dense path constraint (three
//     guidance rows), p50 and p99; and the preparation of a window;
//   - batches of 2, 4 and 8 such windows (several characters) in one call,
//     per window;
//   - one denoiser call with those rows, one decoder call;
//   - text encoding, cold (cache cleared) and cached;
//   - the planner's cost on the caller's thread: advance(), sample_current(),
//     a command, measured per call while the worker generates in the
//     background (a 60 Hz loop in real time);
//   - peak resident memory.
// Not a test: nothing is asserted.
//
//   ardy-bench --package DIR [--threads N] [--repeats N] [--json FILE]
//              [--planner-seconds S] [--label TEXT] [--spin] [--shared-pool] [--future-tokens N]
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
  double planner_seconds = 5.0;
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
    } else if (k == "--planner-seconds") {
      a.planner_seconds = std::stod(value());
    } else if (k == "--label") {
      a.label = value();
    } else if (k == "--future-tokens") {
      a.future_tokens = std::stoi(value());
    } else if (k == "--spin") {
      a.spin = true;
    } else if (k == "--shared-pool") {
      a.shared_pool = true;
    } else {
      std::cerr << "usage: ardy-bench --package DIR [--threads N] [--repeats N] [--json FILE] "
                   "[--planner-seconds S] [--label TEXT] [--spin] [--shared-pool] [--future-tokens N]\n";
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

// A rollout with a full history, a prompt and a long dense path (so every
// window has constraints in and beyond it: three guidance rows).
ardy::RolloutSettings bench_settings(size_t steps, int future_tokens) {
  ardy::RolloutSettings settings;
  settings.steps = steps;
  if (future_tokens >= 0) settings.future_tokens = static_cast<size_t>(future_tokens);
  return settings;
}

ardy::Rollout warm_rollout(const std::shared_ptr<const ardy::ModelPackage>& package, int future_tokens) {
  const ardy::RolloutSettings settings = bench_settings(4, future_tokens);
  ardy::Rollout rollout(package, settings);
  rollout.add_prompt(0, std::string(kPrompt));
  rollout.constraints().add(ardy::path_from_polyline({{0.0, 0.0}, {0.0, 400.0}}, 1.2, 0, package->fps()));
  const size_t max_history = package->tokens().max_history;
  while (rollout.stored_tokens() < max_history) rollout.generate_next_window();
  return rollout;
}

// Times `repeats` windows at `steps`: generate_window only (the model), and
// prepare_window (history, goals, cached text) separately.
void time_windows(ardy::Rollout& rollout, size_t steps, int future_tokens, int repeats,
                  std::vector<double>& window_ms, std::vector<double>& prepare_ms, size_t& rows) {
  rollout.configure(bench_settings(steps, future_tokens));
  for (int i = -2; i < repeats; ++i) {  // two warm-up windows
    auto t0 = Clock::now();
    const ardy::WindowInput in = rollout.prepare_window();
    const double prep = seconds_since(t0) * 1e3;
    const std::vector<float> noise = rollout.draw_noise();
    t0 = Clock::now();
    const ardy::WindowResult out = ardy::generate_window(rollout.package(), in, noise);
    const double ms = seconds_since(t0) * 1e3;
    rollout.commit(out, rollout.package().tokens().window);
    rows = ardy::guidance_rows(in.w_text, in.w_con, in.text_embedding.has_value(), in.goals.has_constraints()).size();
    if (i >= 0) {
      window_ms.push_back(ms);
      prepare_ms.push_back(prep);
    }
  }
}

// Times one batch of `count` windows (copies of one window, the characters of
// a scene) in one generate_windows call: DDIM with every row of every window
// in one denoiser call per step, one decoder call per window.
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

// The denoiser inputs of a window's three rows (D0, D_text, D_con; contract section 2).
std::vector<std::pair<std::string, ardy::Tensor>> denoiser_inputs(const ardy::ModelPackage& p,
                                                                  const ardy::WindowInput& in) {
  const size_t rows = 3;
  const ardy::TokenSizes& t = p.tokens();
  const auto b = static_cast<int64_t>(rows), c = static_cast<int64_t>(t.window), d = static_cast<int64_t>(t.token_dim);
  const auto h = static_cast<int64_t>(in.history_tokens), f = static_cast<int64_t>(in.goals.future_tokens);
  const auto g = static_cast<int64_t>(t.goal_dim), e = static_cast<int64_t>(p.text_embedding_size());
  auto repeat = [&](const std::vector<float>& v) {
    std::vector<float> out;
    for (size_t r = 0; r < rows; ++r) out.insert(out.end(), v.begin(), v.end());
    return out;
  };
  std::vector<std::pair<std::string, ardy::Tensor>> x;
  x.emplace_back("x_t", ardy::Tensor::float32({b, c, d}, std::vector<float>(rows * t.window * t.token_dim, 0.5f)));
  x.emplace_back("step", ardy::Tensor::int64({b}, std::vector<int64_t>(rows, 9)));
  const std::vector<float> text = in.text_embedding.value_or(std::vector<float>(static_cast<size_t>(e), 0.0f));
  x.emplace_back("text_embedding", ardy::Tensor::float32({b, e}, repeat(text)));
  x.emplace_back("text_keep", ardy::Tensor::float32({b}, {0.0f, 1.0f, 0.0f}));
  x.emplace_back("history", ardy::Tensor::float32({b, h, d}, repeat(in.history)));
  x.emplace_back("history_mask", ardy::Tensor::float32({b, h}, std::vector<float>(rows * static_cast<size_t>(h), 1.0f)));
  x.emplace_back("window_goal", ardy::Tensor::float32({b, c, g}, repeat(in.goals.window_goal)));
  x.emplace_back("window_goal_mask", ardy::Tensor::float32({b, c, g}, repeat(in.goals.window_goal_mask)));
  x.emplace_back("future_goal", ardy::Tensor::float32({b, f, g}, repeat(in.goals.future_goal)));
  x.emplace_back("future_goal_mask", ardy::Tensor::float32({b, f, g}, repeat(in.goals.future_goal_mask)));
  x.emplace_back("future_mask", ardy::Tensor::float32({b, f}, repeat(in.goals.future_mask)));
  x.emplace_back("constraint_keep", ardy::Tensor::float32({b}, {0.0f, 0.0f, 1.0f}));
  return x;
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
    ardy::Rollout rollout = warm_rollout(package, args.future_tokens);
    std::vector<double> w4, w10, prep4, prep10;
    size_t rows = 0;
    time_windows(rollout, 4, args.future_tokens, args.repeats, w4, prep4, rows);
    time_windows(rollout, 10, args.future_tokens, std::max(3, args.repeats / 2), w10, prep10, rows);
    rollout.configure(bench_settings(4, args.future_tokens));
    const std::vector<size_t> batch_sizes{1, 2, 4, 8};
    std::vector<Summary> batches;
    for (size_t n : batch_sizes) batches.push_back(summarize(time_batch(rollout, n, std::max(3, args.repeats / 2))));

    // --- single graph calls ------------------------------------------------------------
    const ardy::WindowInput in = rollout.prepare_window();
    const auto inputs = denoiser_inputs(p, in);
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
    const double rss_peak = peak_rss_mb();

    // --- report --------------------------------------------------------------------------
    const Summary s4 = summarize(w4), s10 = summarize(w10), sp4 = summarize(prep4);
    const Summary sd = summarize(denoiser_ms), sdec = summarize(decoder_ms);
    const Summary stc = summarize(text_cold), stw = summarize(text_cached);
    const Summary sadv = summarize(advance_us), ssam = summarize(sample_us), sfr = summarize(frame_us);
    const Summary scmd = summarize(command_us), shot = summarize(sample_hot_us);
    const std::string label = args.label.empty() ? args.package : args.label;
    const std::string text_model = p.text_settings().graph_file + ", " + std::to_string(p.text_embedding_size()) + "-d";

    std::ostringstream o;
    o << "### C++ runtime (ONNX Runtime " << ardy::OnnxEnvironment::runtime_version() << ", " << threads
      << " intra-op thread" << (threads == 1 ? "" : "s") << (args.spin ? " (spinning)" : "")
      << (args.shared_pool ? ", one pool shared by every graph" : "") << ", "
      << std::thread::hardware_concurrency() << " cores)\n\n";
    o << "Model: " << label << " (C = " << t.window << " tokens = " << t.window_frames() << " frames, H = "
      << in.history_tokens << " history tokens, F = " << in.goals.future_tokens << " future tokens, " << rows
      << " guidance rows, L = " << t.latent_dim << "); load " << fmt(load_s, 2) << " s.\n\n";
    o << "| measurement | p50 | p99 | n |\n|---|---|---|---|\n";
    o << "| window, 4 steps (DDIM, " << rows << " rows, decode, FK) | " << fmt(s4.p50) << " ms | " << fmt(s4.p99)
      << " ms | " << s4.count << " |\n";
    for (size_t i = 1; i < batch_sizes.size(); ++i) {
      const Summary& b = batches[i];
      o << "| batch of " << batch_sizes[i] << " windows (characters), 4 steps, one call: per window | "
        << fmt(b.p50 / double(batch_sizes[i])) << " ms | " << fmt(b.p99 / double(batch_sizes[i])) << " ms | " << b.count
        << " |\n";
    }
    o << "| window, 10 steps | " << fmt(s10.p50) << " ms | " << fmt(s10.p99) << " ms | " << s10.count << " |\n";
    o << "| window preparation (history, goals, cached text) | " << fmt(sp4.p50, 3) << " ms | " << fmt(sp4.p99, 3)
      << " ms | " << sp4.count << " |\n";
    o << "| denoiser call, B = 3 rows | " << fmt(sd.p50) << " ms | " << fmt(sd.p99) << " ms | " << sd.count << " |\n";
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
      j["window_tokens"] = t.window;
      j["history_tokens"] = in.history_tokens;
      j["future_tokens"] = in.goals.future_tokens;
      j["rows"] = rows;
      j["text_model"] = text_model;
      j["load_seconds"] = load_s;
      j["window_4_ms"] = to_json(s4);
      j["window_10_ms"] = to_json(s10);
      for (size_t i = 0; i < batch_sizes.size(); ++i) {
        j["batch_window_4_ms"][std::to_string(batch_sizes[i])] = to_json(batches[i]);
      }
      j["prepare_ms"] = to_json(sp4);
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
      std::ofstream(args.json) << j.dump(1) << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "ardy-bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
