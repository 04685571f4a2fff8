// ardy-generate: a JSON timeline of prompts and constraints in, motion out,
// as a BVH file (opens in Blender) and a per-frame JSON.
//
//   ardy-generate --model DIR --timeline TIMELINE.json --seconds S
//                 [--seed N] [--steps K] [--threads N] [--out-bvh out.bvh]
//                 [--out-json out.json] [--w-text W] [--w-con W]
//                 [--history-seconds S] [--smoothing S]
//                 [--interpolate-root on|off] [--max-root-speed V] [--foot-lock on|off]
//                 [--path-guidance-scale S] [--text-only-guidance-scale S]
//
// The timeline schema is timeline.hpp's (export_tools' timeline.py). The
// motion is made by offline_motion.hpp: the frames a game's planner shows for
// the same timeline and seed. Exit
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

#include "bvh.hpp"
#include "error.hpp"
#include "io.hpp"
#include "kinematics.hpp"
#include "motion_filter.hpp"
#include "offline_motion.hpp"
#include "package.hpp"
#include "timeline.hpp"

namespace {

constexpr const char* kUsage =
    "usage: ardy-generate --model DIR --timeline TIMELINE.json --seconds S [--seed N] [--steps K]\n"
    "                     [--out-bvh out.bvh] [--out-json out.json] [--threads N]\n"
    "                     [--w-text W] [--w-con W] [--history-seconds S]\n"
    "                     [--smoothing S] [--interpolate-root on|off] [--max-root-speed V]\n"
    "                     [--foot-lock on|off] [--path-guidance-scale S] [--text-only-guidance-scale S]\n"
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
    "  --path-guidance-scale S  w_con times S where the constraints are a dense root path alone,\n"
    "                         0 < S <= 1 (default: the package's)\n"
    "  --text-only-guidance-scale S  w_text times S where a window has a prompt and no constraints,\n"
    "                         at the steps in the upper half of the schedule, 0 < S <= 4\n"
    "                         (default: the package's)\n"
    "  --history-seconds S    history length (default and maximum: the model's)\n"
    "  --smoothing S          output filter sigma in frames, 0 = raw model output (default: the package's)\n"
    "  --interpolate-root on|off  turn sparse root targets (waypoints, keyframe roots) into a path from\n"
    "                         the character's position (default: the package's)\n"
    "  --max-root-speed V     root targets never ask for more than V m/s, 0 = no limit (default 6)\n"
    "  --foot-lock on|off     hold planted feet in place by leg IK on the output (default on)\n"
    "  --joint-reach on|off   reach joint targets on the output: positions by two-bone IK, rotations by\n"
    "                         turning the joint (default on)\n";

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
  std::optional<double> history_seconds;
  std::optional<double> smoothing;
  std::optional<bool> interpolate_root;
  std::optional<float> path_guidance_scale;
  std::optional<float> text_only_guidance_scale;
  std::optional<double> max_root_speed;
  bool foot_lock = true;
  bool joint_reach = true;
};

Arguments parse_arguments(int argc, char** argv) {
  std::map<std::string, std::string> values;
  const std::vector<std::string> known{"--model",  "--timeline", "--seconds",       "--seed",
                                       "--steps",  "--out-bvh",  "--out-json",      "--threads",
                                       "--w-text", "--w-con",    "--history-seconds", "--joint-reach",
                                       "--smoothing", "--interpolate-root", "--max-root-speed",
                                       "--foot-lock", "--path-guidance-scale", "--text-only-guidance-scale"};
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
  if (values.count("--history-seconds")) a.history_seconds = number("--history-seconds", 0.0, 3600.0);
  if (values.count("--smoothing")) a.smoothing = number("--smoothing", 0.0, ardy::kMaxSmoothingFrames);
  const auto on_off = [&](const char* name) {
    const std::string v = need(name);
    if (v != "on" && v != "off") throw UsageError{std::string(name) + " must be on or off, got '" + v + "'"};
    return v == "on";
  };
  if (values.count("--interpolate-root")) a.interpolate_root = on_off("--interpolate-root");
  if (values.count("--foot-lock")) a.foot_lock = on_off("--foot-lock");
  if (values.count("--joint-reach")) a.joint_reach = on_off("--joint-reach");
  if (values.count("--max-root-speed")) a.max_root_speed = number("--max-root-speed", 0.0, 1000.0);
  if (values.count("--path-guidance-scale")) {
    const double scale = number("--path-guidance-scale", 0.0, 1.0);
    if (!ardy::path_guidance_scale_in_range(scale)) throw UsageError{"--path-guidance-scale must be above 0, got 0"};
    a.path_guidance_scale = static_cast<float>(scale);
  }
  if (values.count("--text-only-guidance-scale")) {
    const double scale = number("--text-only-guidance-scale", 0.0, ardy::kMaxTextOnlyGuidanceScale);
    if (!ardy::text_only_guidance_scale_in_range(scale)) {
      throw UsageError{"--text-only-guidance-scale must be above 0, got 0"};
    }
    a.text_only_guidance_scale = static_cast<float>(scale);
  }
  return a;
}

// --- output ----------------------------------------------------------------------------

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw ardy::Error(path + ": cannot open for writing");
  out << text;
  out.flush();
  if (!out) throw ardy::Error(path + ": cannot write");
}

double rounded(double v) { return std::round(v * 1e6) / 1e6 + 0.0; }

std::string make_json(const ardy::ModelPackage& package, const ardy::OfflineMotion& g, const Arguments& args) {
  using nlohmann::json;
  const ardy::Skeleton& skeleton = package.skeleton();
  const size_t j = skeleton.joint_count();
  json doc;
  doc["format"] = "ardy-motion";
  doc["format_version"] = 1;
  doc["fps"] = package.fps();
  doc["frame_count"] = g.frames.size();
  doc["joints"] = skeleton.names();
  doc["parents"] = skeleton.parents();
  doc["contact_joints"] = package.contact_joints();
  doc["rotation_format"] = "quaternion [x, y, z, w], parent-relative (root: world)";
  doc["units"] = "metres, Y up, heading psi in radians about +Y (0 faces +Z)";
  doc["seed"] = args.seed;
  json windows = json::array();
  for (const ardy::WindowRecord& record : g.windows) {
    json info;
    info["start_frame"] = record.start_frame;
    info["prompt"] = record.prompt ? json(*record.prompt) : json();
    info["history_tokens"] = record.history_tokens;
    windows.push_back(std::move(info));
  }
  doc["windows"] = std::move(windows);
  json frames = json::array();
  for (size_t f = 0; f < g.frames.size(); ++f) {
    const ardy::Pose& pose = g.frames[f];
    json frame;
    frame["frame"] = f;
    frame["time"] = rounded(double(f) / package.fps());
    frame["root_position"] = {rounded(pose.positions[0].x), rounded(pose.positions[0].y), rounded(pose.positions[0].z)};
    frame["heading"] = rounded(pose.heading);
    json pos = json::array(), rot = json::array();
    for (size_t k = 0; k < j; ++k) {
      pos.push_back({rounded(pose.positions[k].x), rounded(pose.positions[k].y), rounded(pose.positions[k].z)});
      // The runtime's convention (kinematics.hpp): the unit quaternion with w >= 0.
      const glm::quat q = ardy::quat_from_matrix(ardy::matrix_from_quat(pose.local_rotations[k]));
      rot.push_back({rounded(q.x), rounded(q.y), rounded(q.z), rounded(q.w)});
    }
    frame["positions"] = std::move(pos);
    frame["local_rotations"] = std::move(rot);
    json contacts = json::array();
    for (float contact : pose.contacts) contacts.push_back(rounded(contact));
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

  const std::string timeline_text = ardy::read_file(args.timeline, "a JSON timeline", size_t{64} << 20);
  ardy::Timeline timeline = ardy::parse_timeline_text(timeline_text, *package, args.timeline);

  ardy::PlannerConfig config;
  config.seed = args.seed;
  config.steps = args.steps;
  config.w_text = args.w_text;
  config.w_con = args.w_con;
  if (args.history_seconds) config.history_seconds = *args.history_seconds;
  config.output_smoothing_frames = args.smoothing;
  config.interpolate_root = args.interpolate_root;
  config.path_guidance_scale = args.path_guidance_scale;
  config.text_only_guidance_scale = args.text_only_guidance_scale;
  if (args.max_root_speed) config.max_root_speed = *args.max_root_speed;
  config.foot_lock = args.foot_lock;
  config.joint_reach = args.joint_reach;
  config.initial_prompts = std::move(timeline.prompts);
  config.initial_constraints = std::move(timeline.constraints);
  const ardy::OfflineMotion motion = ardy::generate_offline(package, std::move(config), args.seconds);

  if (args.out_bvh) write_file(*args.out_bvh, ardy::motion_to_bvh(package->skeleton(), package->fps(), motion.frames));
  if (args.out_json) write_file(*args.out_json, make_json(*package, motion, args));
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::cout << "ardy-generate: " << motion.frames.size() << " frames (" << motion.windows.size() << " windows, "
            << motion.seconds() << " s of motion) in " << elapsed << " s";
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
