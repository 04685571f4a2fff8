// Sampler and Rollout: parity with the Python reference on the tiny package's
// golden vectors (every graph, the per-window inputs of the rollout, the
// whole 4-window rollout), plus DDIM/guidance rules, batching, seeding,
// cancellation and malformed inputs.

#include <catch_amalgamated.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "constraints.hpp"
#include "package.hpp"
#include "rollout.hpp"
#include "sampler.hpp"
#include "support/error_message.hpp"
#include "support/goldens.hpp"
#include "timeline.hpp"

using ardy::Rollout;
using ardy::RolloutSettings;
using ardy::WindowInput;
using ardy::WindowResult;
using ardy_test::check_parity;
using ardy_test::error_message;
using ardy_test::goldens;
using ardy_test::tiny_package;
using Catch::Matchers::ContainsSubstring;

namespace {

std::vector<float> slice(const std::vector<float>& v, size_t begin, size_t count) {
  return std::vector<float>(v.begin() + static_cast<std::ptrdiff_t>(begin),
                            v.begin() + static_cast<std::ptrdiff_t>(begin + count));
}

// The golden rollout's settings, prompts and constraints.
RolloutSettings golden_settings() {
  const nlohmann::json& cfg = goldens().doc().at("rollout").at("config");
  RolloutSettings s;
  s.steps = cfg.at("steps").get<size_t>();
  s.w_text = cfg.at("w_text").get<float>();
  s.w_con = cfg.at("w_con").get<float>();
  s.history_tokens = cfg.at("history_tokens").get<size_t>();
  s.future_tokens = cfg.at("future_tokens").get<size_t>();
  s.decode_context_tokens = cfg.at("decode_context_tokens").get<size_t>();
  s.commit_tokens = cfg.at("commit_tokens").get<size_t>();
  s.start_xz = glm::dvec2(cfg.at("start_xz")[0].get<double>(), cfg.at("start_xz")[1].get<double>());
  s.root_overwrite = cfg.at("root_overwrite").get<bool>();
  s.max_root_speed = 0.0;     // the reference's goals are the constraints as given
  s.root_continuity = false;  // and its overwrite the plain one
  return s;
}

ardy::Timeline golden_timeline() {
  const nlohmann::json& r = goldens().doc().at("rollout");
  nlohmann::json doc;
  doc["prompts"] = r.at("prompts");
  doc["constraints"] = r.at("constraints");
  return ardy::parse_timeline(doc, *tiny_package(), "goldens.json rollout");
}

Rollout golden_rollout() {
  Rollout rollout(tiny_package(), golden_settings());
  const ardy::Timeline timeline = golden_timeline();
  for (const ardy::PromptEvent& e : timeline.prompts) rollout.add_prompt(e.frame, e.text);
  for (const ardy::Constraint& c : timeline.constraints) rollout.constraints().add(c);
  return rollout;
}

std::vector<float> golden_noise(size_t window) {
  const auto& t = tiny_package()->tokens();
  return slice(goldens().floats("rollout/noise"), window * t.window * t.token_dim, t.window * t.token_dim);
}

// Row-major 3x3 per joint (numpy) from GLM matrices.
std::vector<float> matrices_row_major(const std::vector<glm::mat3>& ms) {
  std::vector<float> out;
  out.reserve(ms.size() * 9);
  for (const glm::mat3& m : ms) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) out.push_back(m[c][r]);
    }
  }
  return out;
}

std::vector<float> flatten(const std::vector<glm::vec3>& vs) {
  std::vector<float> out;
  for (const glm::vec3& v : vs) {
    out.push_back(v.x);
    out.push_back(v.y);
    out.push_back(v.z);
  }
  return out;
}

double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  double m = 0.0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(double(a[i]) - double(b[i])));
  return m;
}

}  // namespace

// --- graphs --------------------------------------------------------------------------

TEST_CASE("denoiser graph matches the golden outputs", "[parity][graphs]") {
  const auto package = tiny_package();
  // The history through history.onnx, then the denoiser with its keys and
  // values, against the uncached PyTorch forward of the golden inputs.
  const std::vector<std::pair<std::string, ardy::Tensor>> inputs = ardy_test::golden_denoiser_inputs(*package);
  // The golden inputs have history and future goals (H = 5, F = 3).
  REQUIRE(goldens().shape("denoiser/input/history")[1] == 5);
  REQUIRE(goldens().shape("denoiser/input/future_goal")[1] == 3);
  const std::vector<ardy::Tensor> out = package->denoiser().run(inputs, {"x0"});
  check_parity("denoiser x0 vs ONNX Runtime (Python)", goldens().floats("denoiser/onnx_output/x0"), out[0].data, 1e-6);
  check_parity("denoiser x0 vs PyTorch", goldens().floats("denoiser/output/x0"), out[0].data);
}

TEST_CASE("decoder and encoder graphs match the golden outputs", "[parity][graphs]") {
  const auto package = tiny_package();
  std::vector<std::pair<std::string, ardy::Tensor>> inputs;
  for (const char* name : {"tokens", "prev_root", "prev_root_valid"}) {
    inputs.emplace_back(name, goldens().tensor(std::string("decoder/input/") + name));
  }
  const std::vector<ardy::Tensor> body = package->decoder().run(inputs, {"body"});
  check_parity("decoder body vs PyTorch", goldens().floats("decoder/output/body"), body[0].data);

  const std::vector<ardy::Tensor> latent =
      package->encoder().run({{"body", goldens().tensor("encoder/input/body")}}, {"latent"});
  check_parity("encoder latent vs PyTorch", goldens().floats("encoder/output/latent"), latent[0].data);
}

TEST_CASE("text encoder: our WordPiece ids and the embeddings match the golden prompts", "[parity][graphs]") {
  const auto package = tiny_package();
  const std::vector<std::string> prompts = goldens().doc().at("prompts").get<std::vector<std::string>>();
  const std::vector<int64_t> ids = goldens().ints("text/input/input_ids");
  const std::vector<int64_t> mask = goldens().ints("text/input/attention_mask");
  const std::vector<float> embeddings = goldens().floats("text/output/embedding");
  const size_t width = static_cast<size_t>(goldens().shape("text/input/input_ids")[1]);
  const size_t e = package->text_embedding_size();
  REQUIRE(e == static_cast<size_t>(goldens().shape("text/output/embedding")[1]));
  std::vector<float> ours;
  for (size_t i = 0; i < prompts.size(); ++i) {
    const ardy::WordPieceEncoding enc = package->text_encoder().tokenizer().encode(prompts[i]);
    std::vector<int64_t> expected;
    for (size_t k = 0; k < width; ++k) {
      if (mask[i * width + k]) expected.push_back(ids[i * width + k]);
    }
    CHECK(enc.input_ids == expected);
    const std::vector<float> embedding = package->text_encoder().encode(prompts[i]);
    ours.insert(ours.end(), embedding.begin(), embedding.end());
  }
  check_parity("text embedding vs ONNX Runtime (Python)", embeddings, ours, 1e-5);
  // The batched call (padding) gives the same embeddings.
  package->text_encoder().clear_cache();
  const auto batch = package->text_encoder().encode_batch(prompts);
  std::vector<float> batched;
  for (const auto& b : batch) batched.insert(batched.end(), b.begin(), b.end());
  check_parity("text embedding, batched with padding", embeddings, batched, 1e-5);
}

// --- DDIM and guidance rules ----------------------------------------------------------------

TEST_CASE("DDIM timesteps and coefficients follow diffusion.py", "[sampler]") {
  CHECK(ardy::ddim_timesteps(10, 4) == std::vector<int64_t>{9, 6, 3, 0});
  CHECK(ardy::ddim_timesteps(10, 10) == std::vector<int64_t>{9, 8, 7, 6, 5, 4, 3, 2, 1, 0});
  CHECK(ardy::ddim_timesteps(10, 1) == std::vector<int64_t>{9});
  CHECK(ardy::ddim_timesteps(10, 2) == std::vector<int64_t>{9, 0});
  CHECK(ardy::ddim_timesteps(10, 3) == std::vector<int64_t>{9, 5, 0});  // 4.5 rounds up
  CHECK_THAT(error_message([] { ardy::ddim_timesteps(10, 0); }), ContainsSubstring("1..10"));
  CHECK_THAT(error_message([] { ardy::ddim_timesteps(10, 11); }), ContainsSubstring("got 11"));
  const auto& schedule = tiny_package()->schedule();
  const auto [a, b] = ardy::ddim_coefficients(schedule, 9);
  CHECK(a == static_cast<float>(std::sqrt(schedule.alphas_cumprod[9])));
  CHECK(b == static_cast<float>(std::sqrt(1.0 - schedule.alphas_cumprod[9])));
}

TEST_CASE("guidance rows are D0, D_text, D_con with zero weights skipped", "[sampler]") {
  const auto rows = ardy::guidance_rows(2.0f, 2.0f, true, true);
  REQUIRE(rows.size() == 3);
  CHECK(rows[0].weight == -3.0f);
  CHECK(rows[0].text_keep == 0.0f);
  CHECK(rows[0].constraint_keep == 0.0f);
  CHECK(rows[1].weight == 2.0f);
  CHECK(rows[1].text_keep == 1.0f);
  CHECK(rows[2].constraint_keep == 1.0f);
  const auto no_constraints = ardy::guidance_rows(2.0f, 2.0f, true, false);
  REQUIRE(no_constraints.size() == 2);
  CHECK(no_constraints[0].weight == -1.0f);
  const auto none = ardy::guidance_rows(2.0f, 2.0f, false, false);
  REQUIRE(none.size() == 1);
  CHECK(none[0].weight == 1.0f);
  const auto text_only = ardy::guidance_rows(1.0f, 2.0f, true, false);  // D0 weight 0: skipped
  REQUIRE(text_only.size() == 1);
  CHECK(std::string(text_only[0].name) == "text");
  CHECK(text_only[0].late_weight == 1.0f);
}

TEST_CASE("guidance rows with another late text weight: a row stays where either weight is not 0", "[sampler]") {
  // w_text 1.5 in the upper half of the schedule, 1 below it: D0 has weight
  // -0.5 early and 0 late, so it is run, and weighs nothing in the late steps.
  const auto rows = ardy::guidance_rows(1.5f, 1.0f, 2.0f, true, false);
  REQUIRE(rows.size() == 2);
  CHECK(std::string(rows[0].name) == "uncond");
  CHECK(rows[0].weight == -0.5f);
  CHECK(rows[0].late_weight == 0.0f);
  CHECK(rows[1].weight == 1.5f);
  CHECK(rows[1].late_weight == 1.0f);
  // The goal row keeps its weight at every step.
  const auto with_goals = ardy::guidance_rows(3.0f, 2.0f, 2.0f, true, true);
  REQUIRE(with_goals.size() == 3);
  CHECK(with_goals[0].weight == -4.0f);
  CHECK(with_goals[0].late_weight == -3.0f);
  CHECK(with_goals[2].weight == 2.0f);
  CHECK(with_goals[2].late_weight == 2.0f);
}

TEST_CASE("the late steps are those in the lower half of the schedule", "[sampler]") {
  // 4 of 1000 steps: 999 and 666 early, 333 and 0 late.
  const std::vector<int64_t> timesteps = ardy::ddim_timesteps(1000, 4);
  REQUIRE(timesteps == std::vector<int64_t>{999, 666, 333, 0});
  CHECK_FALSE(ardy::is_late_step(999, 1000));
  CHECK_FALSE(ardy::is_late_step(666, 1000));
  CHECK_FALSE(ardy::is_late_step(500, 1000));
  CHECK(ardy::is_late_step(499, 1000));
  CHECK(ardy::is_late_step(333, 1000));
  CHECK(ardy::is_late_step(0, 1000));
  // One step is all early.
  CHECK_FALSE(ardy::is_late_step(ardy::ddim_timesteps(1000, 1)[0], 1000));
}

// --- the golden rollout -----------------------------------------------------------------------

TEST_CASE("rollout: per-window inputs and the 4-window output match the Python reference", "[parity][rollout]") {
  const auto package = tiny_package();
  const auto& t = package->tokens();
  const nlohmann::json& info = goldens().doc().at("rollout");
  const size_t windows = info.at("windows").get<size_t>();
  const size_t commit = info.at("config").at("commit_tokens").get<size_t>();
  const size_t m = package->layout().feature_size, j = package->skeleton().joint_count();
  Rollout rollout = golden_rollout();

  std::vector<float> features, positions, local, global;
  for (size_t w = 0; w < windows; ++w) {
    const std::string name = "rollout/window" + std::to_string(w) + "/";
    const WindowInput in = rollout.prepare_window();
    CHECK(in.start_frame == info.at("window_starts")[w].get<int64_t>());
    const nlohmann::json& prompt = info.at("window_prompts")[w];
    CHECK(in.prompt.has_value() == !prompt.is_null());
    if (in.prompt && !prompt.is_null()) CHECK(*in.prompt == prompt.get<std::string>());

    // History and offset come from the committed output of the windows
    // before, so they carry the drift of the graphs (ONNX Runtime here,
    // PyTorch in the reference): exact for window 0, ~1e-6 after.
    const std::vector<float> offset = goldens().floats(name + "offset");
    check_parity(name + "offset", offset, {float(in.offset.x), float(in.offset.y)});
    REQUIRE(static_cast<int64_t>(in.history_tokens) == goldens().shape(name + "history")[0]);
    check_parity(name + "history", goldens().floats(name + "history"), in.history);
    REQUIRE(static_cast<int64_t>(in.goals.future_tokens) == goldens().shape(name + "future_goal")[0]);
    // Goals: the golden constraints were written as float32, the reference
    // rasterized their float64 values, hence not bit-exact.
    check_parity(name + "window_goal", goldens().floats(name + "window_goal"), in.goals.window_goal, 1e-6);
    check_parity(name + "window_goal_mask", goldens().floats(name + "window_goal_mask"), in.goals.window_goal_mask,
                 0.0);
    check_parity(name + "future_goal", goldens().floats(name + "future_goal"), in.goals.future_goal, 1e-6);
    check_parity(name + "future_goal_mask", goldens().floats(name + "future_goal_mask"), in.goals.future_goal_mask,
                 0.0);
    check_parity(name + "future_mask", goldens().floats(name + "future_mask"), in.goals.future_mask, 0.0);

    const WindowResult out = ardy::generate_window(*package, in, golden_noise(w));
    REQUIRE(out.frame_count == t.window * t.patch);
    const size_t frames = commit * t.patch;
    features.insert(features.end(), out.features.begin(),
                    out.features.begin() + static_cast<std::ptrdiff_t>(frames * m));
    for (size_t f = 0; f < frames; ++f) {
      const std::vector<glm::vec3> p(out.motion.positions_of(f), out.motion.positions_of(f) + j);
      const std::vector<glm::mat3> l(out.motion.local_rotations_of(f), out.motion.local_rotations_of(f) + j);
      const std::vector<glm::mat3> g(out.motion.global_rotations_of(f), out.motion.global_rotations_of(f) + j);
      const std::vector<float> pf = flatten(p), lf = matrices_row_major(l), gf = matrices_row_major(g);
      positions.insert(positions.end(), pf.begin(), pf.end());
      local.insert(local.end(), lf.begin(), lf.end());
      global.insert(global.end(), gf.begin(), gf.end());
    }
    rollout.commit(out, commit);
    const size_t done = features.size() / m;
    check_parity(name + "committed features",
                 slice(goldens().floats("rollout/output/features"), (done - frames) * m, frames * m),
                 slice(features, (done - frames) * m, frames * m));
  }
  check_parity("rollout features [T, M]", goldens().floats("rollout/output/features"), features);
  check_parity("rollout joint positions [T, J, 3]", goldens().floats("rollout/output/positions"), positions);
  // Rotations come from the 6D features by Gram-Schmidt, which divides by the
  // length of the first column: the random-weight model's Hips 6D at frame 94
  // has |a1| = 0.039, so the features' ~4e-6 drift there becomes ~1.2e-4.
  // The pose step itself is checked exactly below.
  check_parity("rollout local rotations [T, J, 3, 3]", goldens().floats("rollout/output/local_rotations"), local, 5e-4);
  check_parity("rollout global rotations [T, J, 3, 3]", goldens().floats("rollout/output/global_rotations"), global,
               5e-4);

  // The committed state: the last max_history tokens (world root, latent).
  const std::vector<float> tokens = goldens().floats("rollout/output/tokens");
  const size_t stored = rollout.stored_tokens();
  REQUIRE(stored == std::min<size_t>(windows * commit, t.max_history));
  std::vector<float> ours;
  const size_t rd = t.root_token_dim();
  for (size_t k = 0; k < stored; ++k) {
    ours.insert(ours.end(), rollout.world_roots().begin() + k * rd, rollout.world_roots().begin() + (k + 1) * rd);
    ours.insert(ours.end(), rollout.latents().begin() + k * t.latent_dim,
                rollout.latents().begin() + (k + 1) * t.latent_dim);
  }
  check_parity("rollout committed tokens (stored)",
               slice(tokens, (windows * commit - stored) * t.token_dim, stored * t.token_dim), ours);
  CHECK(rollout.committed_tokens() == windows * commit);
}

TEST_CASE("poses from the golden features match the golden poses (6D, local rotations, FK)", "[parity][rollout]") {
  const auto package = tiny_package();
  const std::vector<float> features = goldens().floats("rollout/output/features");
  const size_t frames = features.size() / package->layout().feature_size;
  ardy::Motion motion;
  ardy::features_to_motion(package->skeleton(), package->layout(), features.data(), frames, motion);
  check_parity("pose step: global rotations", goldens().floats("rollout/output/global_rotations"),
               matrices_row_major(motion.global_rotations), 1e-5);
  check_parity("pose step: local rotations", goldens().floats("rollout/output/local_rotations"),
               matrices_row_major(motion.local_rotations), 1e-5);
  check_parity("pose step: joint positions", goldens().floats("rollout/output/positions"), flatten(motion.positions),
               1e-6);
}

TEST_CASE("generate_next_window with the golden noise reproduces the golden features", "[parity][rollout]") {
  Rollout rollout = golden_rollout();
  const auto& t = tiny_package()->tokens();
  const size_t m = tiny_package()->layout().feature_size;
  std::vector<float> features;
  const size_t windows = goldens().doc().at("rollout").at("windows").get<size_t>();
  for (size_t w = 0; w < windows; ++w) {
    const WindowResult out = rollout.generate_next_window(golden_noise(w));
    const size_t frames = rollout.config().commit_tokens * t.patch;
    features.insert(features.end(), out.features.begin(),
                    out.features.begin() + static_cast<std::ptrdiff_t>(frames * m));
  }
  check_parity("rollout features via generate_next_window", goldens().floats("rollout/output/features"), features);
  const int64_t end = static_cast<int64_t>(features.size() / m);
  CHECK(rollout.next_frame() == end);
  // Every golden constraint has been passed or is still ahead.
  for (const auto& e : rollout.constraints().entries()) CHECK(ardy::constraint_frames(e.constraint).second >= end);
}

// --- batching ----------------------------------------------------------------------------------

TEST_CASE("several windows in one denoiser call give each window's own result", "[sampler][batch]") {
  const auto package = tiny_package();
  Rollout a = golden_rollout();
  Rollout b = golden_rollout();
  // b: two windows ahead (history and future goals); a: the first window.
  b.generate_next_window(golden_noise(0));
  b.generate_next_window(golden_noise(1));
  const WindowInput in_a = a.prepare_window();
  WindowInput in_b = b.prepare_window();
  REQUIRE(in_a.history_tokens == 0);
  REQUIRE(in_b.history_tokens > 0);
  REQUIRE(in_b.goals.future_tokens > 0);
  in_b.prompt.reset();  // a different row count per window
  in_b.text_embedding.reset();
  const std::vector<float> noise_a = golden_noise(2), noise_b = golden_noise(3);
  const std::vector<WindowResult> both = ardy::generate_windows(*package, {&in_a, &in_b}, {&noise_a, &noise_b});
  const WindowResult alone_a = ardy::generate_window(*package, in_a, noise_a);
  const WindowResult alone_b = ardy::generate_window(*package, in_b, noise_b);
  CHECK(max_abs_diff(both[0].features, alone_a.features) < 1e-5);
  CHECK(max_abs_diff(both[1].features, alone_b.features) < 1e-5);
  CHECK(max_abs_diff(both[0].tokens, alone_a.tokens) < 1e-5);
  CHECK(max_abs_diff(both[1].tokens, alone_b.tokens) < 1e-5);

  WindowInput other_steps = in_b;
  other_steps.steps = 2;
  CHECK_THAT(error_message([&] { ardy::generate_windows(*package, {&in_a, &other_steps}, {&noise_a, &noise_b}); }),
             ContainsSubstring("shares its steps"));
}

TEST_CASE("path_guidance_scale scales w_con in windows whose goals are a dense root path alone", "[sampler]") {
  const auto package = tiny_package();
  Rollout rollout = golden_rollout();
  WindowInput path_window = rollout.prepare_window();
  REQUIRE(path_window.goals.has_constraints());
  path_window.goals.root_path_only = true;
  const std::vector<float> noise = golden_noise(0);
  const auto run = [&](const WindowInput& base, float w_con, float scale) {
    WindowInput in = base;
    in.w_con = w_con;
    in.path_guidance_scale = scale;
    return ardy::generate_window(*package, in, noise).features;
  };
  // On a path window, w_con 2 at half scale is w_con 1 at full scale, and differs from w_con 2.
  CHECK(max_abs_diff(run(path_window, 2.0f, 0.5f), run(path_window, 1.0f, 1.0f)) < 1e-6);
  CHECK(max_abs_diff(run(path_window, 2.0f, 0.5f), run(path_window, 2.0f, 1.0f)) > 1e-3);
  // Any other window keeps w_con.
  WindowInput other = path_window;
  other.goals.root_path_only = false;
  CHECK(max_abs_diff(run(other, 2.0f, 0.5f), run(other, 2.0f, 1.0f)) < 1e-6);
  CHECK_THAT(error_message([&] { run(other, 2.0f, 1.5f); }), ContainsSubstring("path_guidance_scale is 1.500000"));
}

TEST_CASE("text_only_guidance_scale scales w_text in windows with a prompt and no goals, early steps only", "[sampler]") {
  const auto package = tiny_package();
  Rollout text_rollout(package, golden_settings());
  for (const ardy::PromptEvent& e : golden_timeline().prompts) text_rollout.add_prompt(e.frame, e.text);
  const WindowInput text_window = text_rollout.prepare_window();
  REQUIRE(text_window.text_embedding.has_value());
  REQUIRE_FALSE(text_window.goals.has_constraints());
  const std::vector<float> noise = golden_noise(0);
  const auto run = [&](const WindowInput& base, float w_text, float scale, size_t steps = 4) {
    WindowInput in = base;
    in.w_text = w_text;
    in.text_only_guidance_scale = scale;
    in.steps = steps;
    return ardy::generate_window(*package, in, noise).features;
  };
  // Text alone, one step (all in the upper half of the schedule): w_text 2 at
  // scale 1.5 is w_text 3, and differs from w_text 2.
  CHECK(max_abs_diff(run(text_window, 2.0f, 1.5f, 1), run(text_window, 3.0f, 1.0f, 1)) < 1e-6);
  CHECK(max_abs_diff(run(text_window, 2.0f, 1.5f, 1), run(text_window, 2.0f, 1.0f, 1)) > 1e-3);
  // Four steps: the two late ones keep w_text 2, so the window is neither.
  CHECK(max_abs_diff(run(text_window, 2.0f, 1.5f), run(text_window, 3.0f, 1.0f)) > 1e-3);
  CHECK(max_abs_diff(run(text_window, 2.0f, 1.5f), run(text_window, 2.0f, 1.0f)) > 1e-3);
  // A window with goals keeps w_text.
  Rollout goal_rollout = golden_rollout();
  const WindowInput goal_window = goal_rollout.prepare_window();
  REQUIRE(goal_window.goals.has_constraints());
  CHECK(max_abs_diff(run(goal_window, 2.0f, 1.5f), run(goal_window, 2.0f, 1.0f)) < 1e-6);
  CHECK_THAT(error_message([&] { run(text_window, 2.0f, 0.0f); }),
             ContainsSubstring("text_only_guidance_scale is 0.000000, expected (0, 4]"));
}

TEST_CASE("root_continuity moves the free root positions with the overwrite, so the root has no step",
          "[sampler]") {
  const auto package = tiny_package();
  const auto& t = package->tokens();
  const ardy::FeatureLayout& layout = package->layout();
  RolloutSettings settings;
  settings.interpolate_root = false;  // one constrained frame: the overwrite alone would make a spike
  Rollout rollout(package, settings);
  const int64_t k = 13;  // the waypoint's frame in the window
  rollout.constraints().add(ardy::RootWaypoint{k, 2.5, -1.0, std::nullopt});
  WindowInput in = rollout.prepare_window();
  const std::vector<float> noise = golden_noise(0);
  in.root_continuity = false;
  const WindowResult plain = ardy::generate_window(*package, in, noise);
  in.root_continuity = true;
  const WindowResult continuous = ardy::generate_window(*package, in, noise);
  // Only the last step differs: x0 is the same prediction, plus a displacement
  // on the free root positions that is 0 before the window, reaches the
  // overwrite at frame k and then stays.
  const size_t rs = layout.root_size(), d = t.token_dim, frames = t.window * t.patch;
  const auto entry = [&](const WindowResult& r, size_t f, size_t q) {
    return r.tokens[(f / t.patch) * d + (f % t.patch) * rs + q];
  };
  for (size_t q : {size_t{0}, size_t{2}}) {
    INFO("root entry " << q);
    CHECK_THAT(entry(continuous, k, q) - entry(plain, k, q), Catch::Matchers::WithinAbs(0.0, 1e-6));  // the goal
    const float plain_k_neighbour = entry(plain, k + 1, q);
    const float shift_after = entry(continuous, k + 1, q) - plain_k_neighbour;
    CHECK(std::abs(shift_after) > 1e-3f);  // the random model does not reach the waypoint by itself
    for (size_t f = k + 1; f < frames; ++f) {
      CHECK_THAT(entry(continuous, f, q) - entry(plain, f, q), Catch::Matchers::WithinAbs(shift_after, 1e-4));
    }
    for (size_t f = 0; f < static_cast<size_t>(k); ++f) {
      const float ramp = shift_after * static_cast<float>(f + 1) / static_cast<float>(k + 1);
      CHECK_THAT(entry(continuous, f, q) - entry(plain, f, q), Catch::Matchers::WithinAbs(ramp, 1e-4));
    }
  }
  // Heading and height are not constrained here and stay as predicted.
  for (size_t f = 0; f < frames; ++f) {
    CHECK(entry(continuous, f, 1) == entry(plain, f, 1));
    CHECK(entry(continuous, f, 3) == entry(plain, f, 3));
  }

  // A root target with a height (a keyframe's hips): after it, the ground
  // position keeps the displacement, the height returns to the model's own
  // over 10 frames.
  Rollout with_height(package, settings);
  with_height.constraints().add(ardy::JointTarget{k, 0, glm::dvec3(2.5, 1.4, -1.0), std::nullopt});
  WindowInput hin = with_height.prepare_window();
  hin.root_continuity = false;
  const WindowResult hplain = ardy::generate_window(*package, hin, noise);
  hin.root_continuity = true;
  const WindowResult hcont = ardy::generate_window(*package, hin, noise);
  const float lift = entry(hcont, k + 1, 1) - entry(hplain, k + 1, 1);
  CHECK(std::abs(lift) > 1e-3f);
  for (size_t f = k + 1; f < frames; ++f) {
    INFO("frame " << f);
    const float expected = lift * std::max(0.0f, 1.0f - float(f - k) / 11.0f) / (1.0f - 1.0f / 11.0f);
    CHECK_THAT(entry(hcont, f, 1) - entry(hplain, f, 1), Catch::Matchers::WithinAbs(expected, 1e-4));
    CHECK_THAT(entry(hcont, f, 0) - entry(hplain, f, 0),
               Catch::Matchers::WithinAbs(entry(hcont, k + 1, 0) - entry(hplain, k + 1, 0), 1e-4));
  }
}

// --- seeding, snapshots, settings -------------------------------------------------------------------

TEST_CASE("seeded noise is deterministic and a copied rollout is a snapshot", "[rollout]") {
  RolloutSettings settings;
  settings.seed = 42;
  Rollout first(tiny_package(), settings);
  first.add_prompt(0, std::string("a person walks forward"));
  Rollout second = first;  // snapshot before any window
  const WindowResult r1 = first.generate_next_window();
  const WindowResult r2 = second.generate_next_window();
  CHECK(r1.features == r2.features);
  Rollout third = first;  // snapshot after one window
  CHECK(first.generate_next_window().features == third.generate_next_window().features);

  settings.seed = 43;
  Rollout other(tiny_package(), settings);
  other.add_prompt(0, std::string("a person walks forward"));
  CHECK(other.generate_next_window().features != r1.features);

  // Same distribution check on the generator: mean ~ 0, variance ~ 1.
  ardy::NoiseGenerator gen(7);
  const std::vector<float> n = gen.normal(100000);
  double mean = 0.0, var = 0.0;
  for (float v : n) mean += v;
  mean /= double(n.size());
  for (float v : n) var += (v - mean) * (v - mean);
  var /= double(n.size());
  CHECK(std::fabs(mean) < 0.02);
  CHECK(std::fabs(var - 1.0) < 0.02);
}

TEST_CASE("every step count from 1 to N runs; settings are validated", "[rollout]") {
  const size_t n = tiny_package()->schedule().num_steps();
  for (size_t steps = 1; steps <= n; ++steps) {
    RolloutSettings s;
    s.steps = steps;
    Rollout r(tiny_package(), s);
    const WindowResult out = r.generate_next_window();
    for (float v : out.features) REQUIRE(std::isfinite(v));
  }
  RolloutSettings bad;
  bad.steps = n + 1;
  CHECK_THAT(error_message([&] { Rollout r(tiny_package(), bad); }), ContainsSubstring("steps is 11, expected 1..10"));
  bad = {};
  bad.commit_tokens = 0;
  CHECK_THAT(error_message([&] { Rollout r(tiny_package(), bad); }), ContainsSubstring("commit_tokens is 0"));
  bad = {};
  bad.w_text = std::nanf("");
  CHECK_THAT(error_message([&] { Rollout r(tiny_package(), bad); }), ContainsSubstring("w_text is not finite"));
  bad = {};
  bad.path_guidance_scale = 0.0f;
  CHECK_THAT(error_message([&] { Rollout r(tiny_package(), bad); }),
             ContainsSubstring("path_guidance_scale is 0.000000, expected (0, 1]"));
  bad = {};
  bad.text_only_guidance_scale = 4.5f;
  CHECK_THAT(error_message([&] { Rollout r(tiny_package(), bad); }),
             ContainsSubstring("text_only_guidance_scale is 4.500000, expected (0, 4]"));
  // Limits beyond the model's are clamped.
  RolloutSettings big;
  big.history_tokens = 1000;
  big.future_tokens = 1000;
  Rollout r(tiny_package(), big);
  CHECK(r.config().history_tokens == tiny_package()->tokens().max_history);
  CHECK(r.config().future_tokens == tiny_package()->tokens().max_future);
}

// --- cancellation -------------------------------------------------------------------------------------

TEST_CASE("a cancelled window throws Cancelled and leaves the rollout unchanged", "[rollout][cancel]") {
  Rollout rollout = golden_rollout();
  rollout.generate_next_window(golden_noise(0));
  const Rollout before = rollout;
  int calls = 0;
  const ardy::CancelCheck cancel_on_third = [&] { return ++calls >= 3; };
  CHECK_THROWS_AS(rollout.generate_next_window(cancel_on_third), ardy::Cancelled);
  CHECK(calls == 3);
  CHECK(rollout.next_frame() == before.next_frame());
  CHECK(rollout.world_roots() == before.world_roots());
  // An atomic flag works the same way.
  std::atomic<bool> stop{true};
  CHECK_THROWS_AS(rollout.generate_next_window([&] { return stop.load(); }), ardy::Cancelled);
  // The rollout is still usable and gives what it would have given.
  Rollout copy = before;
  const WindowResult after = rollout.generate_next_window();
  CHECK(after.features == copy.generate_next_window().features);
}

// --- malformed inputs ------------------------------------------------------------------------------------

TEST_CASE("bad prompts and constraints are refused and the rollout stays usable", "[rollout][errors]") {
  Rollout rollout(tiny_package());
  CHECK_THAT(error_message([&] { rollout.add_prompt(0, std::string("")); }), ContainsSubstring("prompt is empty"));
  CHECK_THAT(error_message([&] { rollout.add_prompt(0, std::string(" \t\n ")); }),
             ContainsSubstring("prompt is empty"));
  CHECK_THAT(error_message([&] { rollout.add_prompt(0, std::string(10000, 'a')); }),
             ContainsSubstring("prompt is 10000 characters long; the limit is 2000"));
  CHECK_THAT(error_message([&] { rollout.add_prompt(0, std::string("bad \xff utf8")); }), ContainsSubstring("UTF-8"));
  CHECK(rollout.prompts().empty());

  ardy::RootWaypoint nan_waypoint;
  nan_waypoint.frame = 10;
  nan_waypoint.x = std::nan("");
  CHECK_THAT(error_message([&] { rollout.constraints().add(nan_waypoint); }),
             ContainsSubstring("(RootWaypoint): x is NaN"));
  ardy::RootPath inf_path;
  inf_path.positions = {{0.0, 0.0}, {0.0, INFINITY}};
  CHECK_THAT(error_message([&] { rollout.constraints().add(inf_path); }),
             ContainsSubstring("(RootPath): positions[1].z is +infinity"));
  CHECK(rollout.constraints().empty());

  // Still usable: a long prompt within the limit, a valid constraint.
  rollout.add_prompt(0, std::string(1900, 'a') + " walks");
  ardy::RootWaypoint ok;
  ok.frame = 20;
  ok.x = 1.0;
  ok.z = 2.0;
  rollout.constraints().add(ok);
  const WindowResult out = rollout.generate_next_window();
  for (float v : out.features) REQUIRE(std::isfinite(v));
  CHECK(rollout.next_frame() == 40);
}

TEST_CASE("commit refuses stale windows and bad token counts", "[rollout][errors]") {
  Rollout rollout(tiny_package());
  const WindowInput in = rollout.prepare_window();
  const WindowResult out = ardy::generate_window(rollout.package(), in, rollout.draw_noise());
  CHECK_THAT(error_message([&] { rollout.commit(out, 0); }), ContainsSubstring("expected 1..10"));
  CHECK_THAT(error_message([&] { rollout.commit(out, 11); }), ContainsSubstring("expected 1..10"));
  rollout.commit(out, 3);
  CHECK(rollout.next_frame() == 12);
  CHECK_THAT(error_message([&] { rollout.commit(out, 3); }), ContainsSubstring("stale window"));
  std::vector<float> short_noise(5, 0.0f);
  CHECK_THAT(error_message([&] { rollout.generate_next_window(short_noise); }),
             ContainsSubstring("noise has 5 values"));
  CHECK(rollout.next_frame() == 12);
}

TEST_CASE("prompt timeline: prompt A now, prompt B at frame t", "[rollout]") {
  std::vector<ardy::PromptEvent> events{
      {0, std::string("a")}, {45, std::string("b")}, {45, std::string("c")}, {80, std::nullopt}};
  CHECK(!ardy::active_prompt(events, -1).has_value());
  CHECK(*ardy::active_prompt(events, 44) == "a");
  CHECK(*ardy::active_prompt(events, 45) == "c");  // ties: the later in the list
  CHECK(!ardy::active_prompt(events, 80).has_value());

  Rollout rollout(tiny_package());
  rollout.add_prompt(0, std::string("a person walks forward"));
  rollout.add_prompt(45, std::string("someone waves with the right hand"));
  CHECK(*rollout.prepare_window().prompt == "a person walks forward");
  rollout.generate_next_window();  // frames 0..39
  CHECK(*rollout.prepare_window().prompt == "a person walks forward");
  rollout.generate_next_window();  // 40..79: the window starting at 80 takes B
  CHECK(*rollout.prepare_window().prompt == "someone waves with the right hand");
  CHECK(rollout.prompts().size() == 1);  // A can never be active again
}

TEST_CASE("history is cropped to the configured limit and re-centred by translation only", "[rollout]") {
  RolloutSettings s;
  s.history_tokens = 3;
  s.start_xz = {5.0, -2.0};
  Rollout rollout(tiny_package(), s);
  CHECK(rollout.next_offset() == glm::dvec2(5.0, -2.0));
  rollout.generate_next_window();
  rollout.generate_next_window();
  const WindowInput in = rollout.prepare_window();
  CHECK(in.history_tokens == 3);
  const auto last = rollout.last_root();
  REQUIRE(last.has_value());
  CHECK(in.offset == glm::dvec2((*last)[0], (*last)[2]));
  // The last history frame's root is at the origin in x and z.
  const auto& t = tiny_package()->tokens();
  const auto& norm = tiny_package()->feature_normalization();
  const float* root = in.history.data() + 2 * t.token_dim + (t.patch - 1) * 5;
  CHECK(std::fabs(root[0] * norm.stddev()[0] + norm.mean()[0]) < 1e-5);
  CHECK(std::fabs(root[2] * norm.stddev()[2] + norm.mean()[2]) < 1e-5);
  CHECK(rollout.stored_tokens() == t.max_history);
  CHECK(rollout.last_root_velocity().has_value());
}

TEST_CASE("seed_history encodes an animation into the history", "[rollout]") {
  const auto package = tiny_package();
  const auto& t = package->tokens();
  const size_t m = package->layout().feature_size;
  const std::vector<float> features = goldens().floats("rollout/output/features");
  Rollout rollout(package);
  rollout.seed_history(slice(features, 0, 40 * m), 40);
  CHECK(rollout.next_frame() == 0);
  CHECK(rollout.stored_tokens() == std::min<size_t>(10, t.max_history));
  const WindowInput in = rollout.prepare_window();
  CHECK(in.history_tokens == std::min<size_t>(10, t.max_history));
  const float* last_frame = features.data() + 39 * m;
  CHECK(in.offset == glm::dvec2(last_frame[0], last_frame[2]));
  const WindowResult out = rollout.generate_next_window();
  for (float v : out.features) REQUIRE(std::isfinite(v));
  CHECK_THAT(error_message([&] { rollout.seed_history(slice(features, 0, 6 * m), 6); }),
             ContainsSubstring("multiple of the patch size 4"));
  std::vector<float> bad = slice(features, 0, 8 * m);
  bad[3 * m + 7] = std::nanf("");
  CHECK_THAT(error_message([&] { rollout.seed_history(bad, 8); }),
             ContainsSubstring("feature 7 of frame 3 is not finite"));
}

TEST_CASE("rollouts on several threads share one package", "[rollout][threads]") {
  // A planner runs windows on a worker while other characters use the same
  // package: sessions and the text cache are shared (checked under TSan).
  const Rollout start = golden_rollout();
  Rollout reference = start;
  const WindowResult expected = reference.generate_next_window();
  std::vector<WindowResult> results(3);
  std::vector<std::thread> threads;
  for (size_t i = 0; i < results.size(); ++i) {
    threads.emplace_back([&, i] {
      Rollout mine = start;
      tiny_package()->text_encoder().encode(i % 2 ? "someone runs" : "someone jumps");
      results[i] = mine.generate_next_window();
    });
  }
  for (std::thread& t : threads) t.join();
  for (const WindowResult& r : results) CHECK(max_abs_diff(r.features, expected.features) < 1e-5);
}

// Window latency is measured by bench/run.sh (ardy-bench), not here: tests never time.
