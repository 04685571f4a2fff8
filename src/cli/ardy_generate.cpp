// ardy-generate: a JSON timeline of prompts and constraints in, motion out,
// as a BVH file (opens in Blender) and a per-frame JSON.
//
//   ardy-generate --model DIR --timeline TIMELINE.json --seconds S
//                 [--seed N] [--steps K] [--threads N] [--out-bvh out.bvh]
//                 [--out-json out.json] [--w-text W] [--w-con W]
//                 [--commit-tokens N] [--history-seconds S] [--smoothing S]
//                 [--interpolate-root on|off] [--max-root-speed V] [--foot-lock on|off]
//
// The timeline schema is timeline.hpp's (export_tools' timeline.py). Exit
// codes: 0 success, 1 a runtime failure (bad model, bad timeline, I/O), 2 bad
// arguments; the message goes to stderr.

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "error.hpp"
#include "io.hpp"
#include "kinematics.hpp"
#include "foot_lock.hpp"
#include "motion_filter.hpp"
#include "package.hpp"
#include "rollout.hpp"
#include "sampler.hpp"
#include "timeline.hpp"

namespace {

constexpr const char* kUsage =
    "usage: ardy-generate --model DIR --timeline TIMELINE.json --seconds S [--seed N] [--steps K]\n"
    "                     [--out-bvh out.bvh] [--out-json out.json] [--threads N]\n"
    "                     [--w-text W] [--w-con W] [--commit-tokens N] [--history-seconds S]\n"
    "                     [--smoothing S] [--interpolate-root on|off] [--max-root-speed V]\n"
    "                     [--foot-lock on|off]\n"
    "\n"
    "  --model DIR            model package folder (model.json, graphs, vocab.txt)\n"
    "  --timeline FILE        JSON timeline: {\"prompts\": [{\"time\", \"text\"}], \"constraints\": [...]}\n"
    "  --seconds S            length of the motion to generate (0 < S <= 3600)\n"
    "  --seed N               noise seed (default 0)\n"
    "  --steps K              DDIM steps, 1..diffusion steps of the model (default: the package's)\n"
    "  --out-bvh FILE         write a BVH file (Euler ZXY in degrees, metres)\n"
    "  --out-json FILE        write per-frame JSON (positions, local rotations as quaternions, contacts)\n"
    "  --threads N            ONNX Runtime intra-op threads (default: all cores but one)\n"
    "  --w-text W, --w-con W  guidance weights (default: the package's)\n"
    "  --commit-tokens N      tokens kept per window, 1..window (default: the whole window)\n"
    "  --history-seconds S    history length (default and maximum: the model's)\n"
    "  --smoothing S          output filter sigma in frames, 0 = raw model output (default: the package's)\n"
    "  --interpolate-root on|off  turn sparse root targets (waypoints, keyframe roots) into a path from\n"
    "                         the character's position (default: the package's)\n"
    "  --max-root-speed V     root targets never ask for more than V m/s, 0 = no limit (default 6)\n"
    "  --foot-lock on|off     hold planted feet in place by leg IK on the output (default on)\n";

// A bad command line: exit code 2.
struct UsageError {
  std::string message;
};

std::optional<double> parse_double(const std::string& text) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long long> parse_integer(const std::string& text) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || errno == ERANGE) return std::nullopt;
  return v;
}

struct Arguments {
  std::string model;
  std::string timeline;
  double seconds = 0.0;
  uint64_t seed = 0;
  std::optional<size_t> steps;
  std::optional<std::string> out_bvh;
  std::optional<std::string> out_json;
  int threads = 0;
  std::optional<float> w_text;
  std::optional<float> w_con;
  std::optional<size_t> commit_tokens;
  std::optional<double> history_seconds;
  std::optional<double> smoothing;
  std::optional<bool> interpolate_root;
  std::optional<double> max_root_speed;
  bool foot_lock = true;
};

Arguments parse_arguments(int argc, char** argv) {
  std::map<std::string, std::string> values;
  const std::vector<std::string> known{"--model",  "--timeline", "--seconds",       "--seed",
                                       "--steps",  "--out-bvh",  "--out-json",      "--threads",
                                       "--w-text", "--w-con",    "--commit-tokens", "--history-seconds",
                                       "--smoothing", "--interpolate-root", "--max-root-speed",
                                       "--foot-lock"};
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    std::string value;
    const size_t eq = arg.find('=');
    bool inline_value = false;
    if (arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
      inline_value = true;
    }
    if (std::find(known.begin(), known.end(), arg) == known.end()) {
      throw UsageError{"unknown argument '" + arg + "'"};
    }
    if (!inline_value) {
      if (i + 1 >= argc) throw UsageError{arg + " needs a value"};
      value = argv[++i];
    }
    if (!values.emplace(arg, value).second) throw UsageError{arg + " is given more than once"};
  }
  const auto need = [&](const char* name) -> const std::string& {
    const auto it = values.find(name);
    if (it == values.end()) throw UsageError{std::string("missing ") + name};
    return it->second;
  };
  const auto number = [&](const char* name, double min, double max) {
    const std::string& text = need(name);
    const auto v = parse_double(text);
    if (!v || *v < min || *v > max) {
      std::ostringstream range;
      range << min << ".." << max;
      throw UsageError{std::string(name) + " is '" + text + "', expected a number in " + range.str()};
    }
    return *v;
  };
  const auto integer = [&](const char* name, long long min, long long max) {
    const std::string& text = need(name);
    const auto v = parse_integer(text);
    if (!v || *v < min || *v > max) {
      throw UsageError{std::string(name) + " is '" + text + "', expected an integer in " + std::to_string(min) + ".." +
                       std::to_string(max)};
    }
    return *v;
  };
  Arguments a;
  a.model = need("--model");
  a.timeline = need("--timeline");
  a.seconds = number("--seconds", 0.0, 3600.0);
  if (!(a.seconds > 0.0)) throw UsageError{"--seconds must be positive"};
  if (values.count("--seed")) a.seed = static_cast<uint64_t>(integer("--seed", 0, std::numeric_limits<long long>::max()));
  if (values.count("--steps")) a.steps = static_cast<size_t>(integer("--steps", 1, 100000));
  if (values.count("--out-bvh")) a.out_bvh = need("--out-bvh");
  if (values.count("--out-json")) a.out_json = need("--out-json");
  if (values.count("--threads")) a.threads = static_cast<int>(integer("--threads", 1, 1024));
  if (values.count("--w-text")) a.w_text = static_cast<float>(number("--w-text", -100.0, 100.0));
  if (values.count("--w-con")) a.w_con = static_cast<float>(number("--w-con", -100.0, 100.0));
  if (values.count("--commit-tokens")) a.commit_tokens = static_cast<size_t>(integer("--commit-tokens", 1, 100000));
  if (values.count("--history-seconds")) a.history_seconds = number("--history-seconds", 0.0, 3600.0);
  if (values.count("--smoothing")) a.smoothing = number("--smoothing", 0.0, ardy::kMaxSmoothingFrames);
  const auto on_off = [&](const char* name) {
    const std::string v = need(name);
    if (v != "on" && v != "off") throw UsageError{std::string(name) + " must be on or off, got '" + v + "'"};
    return v == "on";
  };
  if (values.count("--interpolate-root")) a.interpolate_root = on_off("--interpolate-root");
  if (values.count("--foot-lock")) a.foot_lock = on_off("--foot-lock");
  if (values.count("--max-root-speed")) a.max_root_speed = number("--max-root-speed", 0.0, 1000.0);
  return a;
}

// --- output ----------------------------------------------------------------------------

struct Generated {
  size_t frame_count = 0;
  std::vector<float> features;  // [T, M]
  ardy::Motion motion;          // [T, J]
  std::vector<nlohmann::json> windows;
};

// R = Rz(z) Rx(x) Ry(y): BVH channels "Zrotation Xrotation Yrotation" (degrees).
glm::vec3 euler_zxy_degrees(const glm::mat3& r) {
  const auto m = [&](int row, int col) { return double(r[col][row]); };
  constexpr double kDeg = 57.29577951308232;
  const double sx = std::clamp(m(2, 1), -1.0, 1.0);
  const double x = std::asin(sx);
  double z = 0.0, y = 0.0;
  if (std::fabs(sx) < 0.9999999) {
    z = std::atan2(-m(0, 1), m(1, 1));
    y = std::atan2(-m(2, 0), m(2, 2));
  } else {  // gimbal lock: put the whole turn into z
    z = std::atan2(m(1, 0), m(0, 0));
  }
  return glm::vec3(float(z * kDeg), float(x * kDeg), float(y * kDeg));
}

std::string fixed(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6f", std::fabs(v) < 5e-7 ? 0.0 : v);
  return buffer;
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw ardy::Error(path + ": cannot open for writing");
  out << text;
  out.flush();
  if (!out) throw ardy::Error(path + ": cannot write");
}

std::string make_bvh(const ardy::ModelPackage& package, const Generated& g) {
  const ardy::Skeleton& skeleton = package.skeleton();
  const size_t joints = skeleton.joint_count();
  std::ostringstream out;
  out << "HIERARCHY\n";
  // Depth-first, children in joint order (parents come first, so joint 0 is the root).
  std::vector<size_t> order;
  const auto emit = [&](const auto& self, size_t j, int depth) -> void {
    const std::string pad(size_t(depth) * 2, ' ');
    const glm::vec3 o = j == 0 ? glm::vec3(0.0f) : skeleton.offset(j);
    out << pad << (j == 0 ? "ROOT " : "JOINT ") << skeleton.name(j) << "\n" << pad << "{\n";
    out << pad << "  OFFSET " << fixed(o.x) << " " << fixed(o.y) << " " << fixed(o.z) << "\n";
    if (j == 0) {
      out << pad << "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n";
    } else {
      out << pad << "  CHANNELS 3 Zrotation Xrotation Yrotation\n";
    }
    order.push_back(j);
    const std::vector<size_t> children = skeleton.children(j);
    for (size_t child : children) self(self, child, depth + 1);
    if (children.empty()) {
      // A short bone tip along the joint's own direction (Blender needs a tail).
      const float length = glm::length(o);
      const glm::vec3 tip = length > 1e-6f ? o * (std::max(0.05f, 0.5f * length) / length) : glm::vec3(0, 0.05f, 0);
      out << pad << "  End Site\n" << pad << "  {\n";
      out << pad << "    OFFSET " << fixed(tip.x) << " " << fixed(tip.y) << " " << fixed(tip.z) << "\n";
      out << pad << "  }\n";
    }
    out << pad << "}\n";
  };
  emit(emit, 0, 0);
  out << "MOTION\n";
  out << "Frames: " << g.frame_count << "\n";
  char frame_time[64];
  std::snprintf(frame_time, sizeof frame_time, "%.8f", 1.0 / package.fps());
  out << "Frame Time: " << frame_time << "\n";
  for (size_t f = 0; f < g.frame_count; ++f) {
    const glm::mat3* local = g.motion.local_rotations_of(f);
    const glm::vec3& root = g.motion.positions_of(f)[0];
    std::string line = fixed(root.x) + " " + fixed(root.y) + " " + fixed(root.z);
    for (size_t j : order) {
      const glm::vec3 e = euler_zxy_degrees(local[j]);
      line += " " + fixed(e.x) + " " + fixed(e.y) + " " + fixed(e.z);
    }
    out << line << "\n";
  }
  (void)joints;
  return out.str();
}

double rounded(double v) { return std::round(v * 1e6) / 1e6 + 0.0; }

std::string make_json(const ardy::ModelPackage& package, const Generated& g, const Arguments& args) {
  using nlohmann::json;
  const ardy::Skeleton& skeleton = package.skeleton();
  const ardy::FeatureLayout& layout = package.layout();
  const size_t j = skeleton.joint_count(), m = layout.feature_size;
  json doc;
  doc["format"] = "ardy-motion";
  doc["format_version"] = 1;
  doc["fps"] = package.fps();
  doc["frame_count"] = g.frame_count;
  doc["joints"] = skeleton.names();
  doc["parents"] = skeleton.parents();
  doc["contact_joints"] = package.contact_joints();
  doc["rotation_format"] = "quaternion [x, y, z, w], parent-relative (root: world)";
  doc["units"] = "metres, Y up, heading psi in radians about +Y (0 faces +Z)";
  doc["seed"] = args.seed;
  doc["windows"] = g.windows;
  json frames = json::array();
  for (size_t f = 0; f < g.frame_count; ++f) {
    const float* row = g.features.data() + f * m;
    json frame;
    frame["frame"] = f;
    frame["time"] = rounded(double(f) / package.fps());
    const glm::vec3* positions = g.motion.positions_of(f);
    frame["root_position"] = {rounded(positions[0].x), rounded(positions[0].y), rounded(positions[0].z)};
    frame["heading"] = rounded(ardy::heading_angle(row[layout.heading.start], row[layout.heading.start + 1]));
    json pos = json::array(), rot = json::array();
    const glm::mat3* local = g.motion.local_rotations_of(f);
    for (size_t k = 0; k < j; ++k) {
      pos.push_back({rounded(positions[k].x), rounded(positions[k].y), rounded(positions[k].z)});
      const glm::quat q = ardy::quat_from_matrix(local[k]);
      rot.push_back({rounded(q.x), rounded(q.y), rounded(q.z), rounded(q.w)});
    }
    frame["positions"] = std::move(pos);
    frame["local_rotations"] = std::move(rot);
    json contacts = json::array();
    for (size_t c = 0; c < layout.contact_count(); ++c)
      contacts.push_back(rounded(row[layout.foot_contacts.start + c]));
    frame["contacts"] = std::move(contacts);
    frames.push_back(std::move(frame));
  }
  // The header indented, then one frame per line.
  std::string out = "{\n";
  for (auto it = doc.begin(); it != doc.end(); ++it) out += " " + json(it.key()).dump() + ": " + it->dump() + ",\n";
  out += " \"frames\": [\n";
  for (size_t f = 0; f < frames.size(); ++f) out += "  " + frames[f].dump() + (f + 1 < frames.size() ? ",\n" : "\n");
  out += " ]\n}\n";
  return out;
}

int run(const Arguments& args) {
  const auto started = std::chrono::steady_clock::now();
  ardy::PackageOptions options;
  options.session.intra_op_threads = args.threads;
  const auto package = std::make_shared<const ardy::ModelPackage>(ardy::ModelPackage::from_folder(args.model, options));
  const ardy::TokenSizes& t = package->tokens();

  const std::string timeline_text = ardy::read_file(args.timeline, "a JSON timeline", size_t{64} << 20);
  const ardy::Timeline timeline = ardy::parse_timeline_text(timeline_text, *package, args.timeline);

  ardy::RolloutSettings settings;
  settings.seed = args.seed;
  settings.steps = args.steps;
  settings.w_text = args.w_text;
  settings.w_con = args.w_con;
  settings.commit_tokens = args.commit_tokens;
  settings.interpolate_root = args.interpolate_root;
  if (args.max_root_speed) settings.max_root_speed = *args.max_root_speed;
  if (args.history_seconds) {
    settings.history_tokens =
        static_cast<size_t>(std::llround(*args.history_seconds * package->fps() / double(t.patch)));
  }
  ardy::Rollout rollout(package, settings);
  for (const ardy::PromptEvent& event : timeline.prompts) rollout.add_prompt(event.frame, event.text);
  for (const ardy::Constraint& c : timeline.constraints) rollout.constraints().add(c);

  const auto wanted = static_cast<size_t>(std::max<long long>(1, std::llround(args.seconds * package->fps())));
  const ardy::FeatureLayout& layout = package->layout();
  const size_t j = package->skeleton().joint_count();
  const double sigma = args.smoothing.value_or(package->sampling_defaults().output_smoothing_frames);
  const ardy::FootLocker feet(package->skeleton(), layout, package->contact_joints());
  ardy::FootLockState feet_state;
  Generated g;
  g.motion.joint_count = j;
  while (g.frame_count < wanted) {
    const ardy::WindowResult window = rollout.generate_next_window();
    const size_t keep = std::min(rollout.config().commit_tokens * t.patch, wanted - g.frame_count);
    // The same output filter as the planner: each window's frames, with the
    // frames already written before them as context (they stay as they are).
    const std::vector<float> shown =
        ardy::smooth_features(layout, g.features.data(), g.frame_count, window.features.data(), keep, sigma);
    g.features.insert(g.features.end(), shown.begin(), shown.end());
    ardy::Motion motion;
    ardy::features_to_motion(package->skeleton(), layout, shown.data(), keep, motion);
    if (args.foot_lock) {
      const float* goal_mask = window.goal_mask.empty() ? nullptr : window.goal_mask.data();
      feet.apply(shown.data(), motion, feet_state, nullptr, goal_mask);
    }
    const auto take = [&](const auto& from, auto& to) { to.insert(to.end(), from.begin(), from.end()); };
    take(motion.global_rotations, g.motion.global_rotations);
    take(motion.local_rotations, g.motion.local_rotations);
    take(motion.positions, g.motion.positions);
    g.frame_count += keep;
    g.motion.frame_count = g.frame_count;
    nlohmann::json info;
    info["start_frame"] = window.start_frame;
    info["prompt"] = window.prompt ? nlohmann::json(*window.prompt) : nlohmann::json();
    info["history_tokens"] = window.history_tokens;
    g.windows.push_back(std::move(info));
  }
  if (args.out_bvh) write_file(*args.out_bvh, make_bvh(*package, g));
  if (args.out_json) write_file(*args.out_json, make_json(*package, g, args));
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::cout << "ardy-generate: " << g.frame_count << " frames (" << g.windows.size() << " windows, "
            << double(g.frame_count) / package->fps() << " s of motion) in " << elapsed << " s";
  if (args.out_bvh) std::cout << " -> " << *args.out_bvh;
  if (args.out_json) std::cout << (args.out_bvh ? ", " : " -> ") << *args.out_json;
  std::cout << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    }
  }
  Arguments args;
  try {
    args = parse_arguments(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << "ardy-generate: " << e.message << "\n" << kUsage;
    return 2;
  }
  try {
    return run(args);
  } catch (const ardy::Error& e) {
    std::cerr << "ardy-generate: error: " << e.what() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "ardy-generate: unexpected error: " << e.what() << "\n";
  }
  return 1;
}
