// ardy-generate on the tiny package: the BVH parses (hierarchy, channel and
// frame counts) and its Euler angles and offsets reproduce the JSON's joint
// positions by FK; the JSON has one entry per frame; bad arguments and bad
// timelines exit non-zero with the message on stderr.

#include <catch_amalgamated.hpp>

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include "support/test_data.hpp"

#ifndef ARDY_GENERATE_EXE
#error "ARDY_GENERATE_EXE must be defined by the build (tests/cpp/CMakeLists.txt)"
#endif

using Catch::Matchers::ContainsSubstring;
namespace fs = std::filesystem;

namespace {

struct RunResult {
  int code = -1;
  std::string out;
  std::string err;
};

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// One scratch folder per test process, removed when the process exits so
// repeated runs leave nothing behind in the temp directory.
struct ScratchDir {
  fs::path path = fs::temp_directory_path() / ("ardy_test_cli_" + std::to_string(::getpid()));
  ScratchDir() { fs::create_directories(path); }
  ~ScratchDir() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
};

fs::path work_dir() {
  static const ScratchDir dir;
  return dir.path;
}

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

RunResult run_cli(const std::string& args) {
  const fs::path out = work_dir() / "stdout.txt", err = work_dir() / "stderr.txt";
  const std::string command =
      quote(ARDY_GENERATE_EXE) + " " + args + " > " + quote(out.string()) + " 2> " + quote(err.string());
  const int status = std::system(command.c_str());
  RunResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

fs::path write_timeline(const std::string& name, const std::string& text) {
  const fs::path path = work_dir() / name;
  std::ofstream(path) << text;
  return path;
}

const char* const kTimeline = R"({
  "prompts": [{"time": 0, "text": "a person walks forward"}, {"time": 1.5, "text": "someone waves with the right hand"}],
  "constraints": [
    {"type": "waypoint", "time": 1.0, "x": 0.5, "z": 1.0, "heading": 0.3},
    {"type": "path", "start_time": 1.5, "points": [[0.5, 1.0], [0.5, 2.0]], "speed": 1.2},
    {"type": "joint", "time": 2.0, "joint": "Hand_R", "position": [0.3, 1.4, 0.2]},
    {"type": "contact", "start_time": 0.5, "end_time": 1.0, "feet": [0, 1]},
    {"type": "clicks", "start_time": 2.2, "points": [[0.5, 2.0], [1.0, 2.5], [1.5, 2.5]], "speed": 1.0}
  ]})";

std::string model_dir() { return ardy_test::data_path("tiny_package"); }

// A parsed BVH: joints in file order with their parent, offset and channel count.
struct Bvh {
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<glm::vec3> offsets;
  std::vector<int> channels;
  int frames = -1;
  double frame_time = 0.0;
  std::vector<std::vector<double>> motion;
};

Bvh parse_bvh(const std::string& text) {
  Bvh bvh;
  std::istringstream in(text);
  std::string word;
  in >> word;
  REQUIRE(word == "HIERARCHY");
  std::vector<int> stack;
  int pending = -1;  // joint whose '{' comes next; -2 for an End Site
  bool in_end_site = false;
  while (in >> word) {
    if (word == "ROOT" || word == "JOINT") {
      std::string name;
      in >> name;
      bvh.names.push_back(name);
      bvh.parents.push_back(stack.empty() ? -1 : stack.back());
      bvh.offsets.emplace_back(0.0f);
      bvh.channels.push_back(0);
      pending = int(bvh.names.size()) - 1;
    } else if (word == "End") {
      in >> word;
      REQUIRE(word == "Site");
      pending = -2;
    } else if (word == "{") {
      if (pending == -2) {
        in_end_site = true;
      } else {
        REQUIRE(pending >= 0);
        stack.push_back(pending);
      }
      pending = -1;
    } else if (word == "}") {
      if (in_end_site) {
        in_end_site = false;
      } else {
        REQUIRE(!stack.empty());
        stack.pop_back();
      }
    } else if (word == "OFFSET") {
      glm::vec3 o;
      in >> o.x >> o.y >> o.z;
      if (!in_end_site) bvh.offsets[size_t(stack.back())] = o;
    } else if (word == "CHANNELS") {
      int n = 0;
      in >> n;
      bvh.channels[size_t(stack.back())] = n;
      for (int i = 0; i < n; ++i) in >> word;
    } else if (word == "MOTION") {
      break;
    } else {
      FAIL("unexpected BVH word '" << word << "'");
    }
  }
  REQUIRE(stack.empty());
  in >> word;
  REQUIRE(word == "Frames:");
  in >> bvh.frames >> word;
  REQUIRE(word == "Frame");
  in >> word >> bvh.frame_time;
  REQUIRE(word == "Time:");
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::istringstream values(line);
    std::vector<double> row;
    double v = 0.0;
    while (values >> v) row.push_back(v);
    bvh.motion.push_back(row);
  }
  return bvh;
}

glm::mat3 rotation_zxy_degrees(double z, double x, double y) {
  const auto axis = [](double degrees, const glm::vec3& a) {
    return glm::mat3(glm::rotate(glm::mat4(1.0f), float(degrees * M_PI / 180.0), a));
  };
  return axis(z, {0, 0, 1}) * axis(x, {1, 0, 0}) * axis(y, {0, 1, 0});
}

}  // namespace

TEST_CASE("ardy-generate writes a BVH and a per-frame JSON that agree", "[cli]") {
  const fs::path timeline = write_timeline("timeline.json", kTimeline);
  const fs::path bvh_path = work_dir() / "out.bvh", json_path = work_dir() / "out.json";
  const RunResult r = run_cli("--model " + quote(model_dir()) + " --timeline " + quote(timeline.string()) +
                              " --seconds 3 --seed 3 --steps 2 --threads 1 --out-bvh " + quote(bvh_path.string()) +
                              " --out-json " + quote(json_path.string()));
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.out, ContainsSubstring("60 frames (2 windows"));

  const Bvh bvh = parse_bvh(read_text(bvh_path));
  REQUIRE(bvh.names.size() == 21);
  CHECK(bvh.names[0] == "Hips");
  CHECK(bvh.channels[0] == 6);
  int channels = 0;
  for (int c : bvh.channels) channels += c;
  CHECK(channels == 6 + 3 * 20);
  CHECK(bvh.frames == 60);
  CHECK(bvh.frame_time == Catch::Approx(0.05));
  REQUIRE(bvh.motion.size() == 60);
  for (const auto& row : bvh.motion) REQUIRE(row.size() == size_t(channels));

  const std::vector<unsigned char> bytes = ardy_test::read_bytes(json_path.string());
  const nlohmann::json doc = nlohmann::json::parse(bytes.begin(), bytes.end());
  CHECK(doc.at("fps").get<double>() == 20.0);
  CHECK(doc.at("frame_count").get<int>() == 60);
  REQUIRE(doc.at("frames").size() == 60);
  CHECK(doc.at("joints").size() == 21);
  CHECK(doc.at("frames")[0].at("contacts").size() == 4);

  // FK of the BVH (Euler ZXY, offsets, hierarchy) gives the JSON's positions.
  const std::vector<std::string> json_joints = doc.at("joints").get<std::vector<std::string>>();
  double worst = 0.0;
  for (size_t f = 0; f < 60; ++f) {
    const std::vector<double>& row = bvh.motion[f];
    std::vector<glm::mat3> global(bvh.names.size());
    std::vector<glm::vec3> pos(bvh.names.size());
    size_t at = 0;
    for (size_t j = 0; j < bvh.names.size(); ++j) {
      glm::vec3 translation(0.0f);
      if (bvh.channels[j] == 6) {
        translation = glm::vec3(float(row[at]), float(row[at + 1]), float(row[at + 2]));
        at += 3;
      }
      const glm::mat3 local = rotation_zxy_degrees(row[at], row[at + 1], row[at + 2]);
      at += 3;
      if (bvh.parents[j] < 0) {
        global[j] = local;
        pos[j] = translation + bvh.offsets[j];
      } else {
        const auto p = size_t(bvh.parents[j]);
        global[j] = global[p] * local;
        pos[j] = pos[p] + global[p] * bvh.offsets[j];
      }
    }
    const nlohmann::json& positions = doc.at("frames")[f].at("positions");
    for (size_t j = 0; j < bvh.names.size(); ++j) {
      const size_t k = size_t(std::find(json_joints.begin(), json_joints.end(), bvh.names[j]) - json_joints.begin());
      REQUIRE(k < json_joints.size());
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(double(pos[j][c]) - positions[k][c].get<double>()));
    }
  }
  INFO("worst BVH FK vs JSON position difference " << worst);
  CHECK(worst < 1e-4);

  // The same seed gives the same file.
  const fs::path again = work_dir() / "again.bvh";
  REQUIRE(run_cli("--model " + quote(model_dir()) + " --timeline " + quote(timeline.string()) +
                  " --seconds 3 --seed 3 --steps 2 --threads 1 --out-bvh " + quote(again.string()))
              .code == 0);
  CHECK(read_text(again) == read_text(bvh_path));
}

TEST_CASE("ardy-generate limits the root's speed toward a far waypoint unless told otherwise", "[cli]") {
  // 30 m in one second: the hips may only get 6 m closer (plus the model's own
  // step), or reach it with --max-root-speed 0.
  const fs::path timeline = write_timeline("far.json", R"({"prompts": [{"time": 0, "text": "walk"}],
    "constraints": [{"type": "waypoint", "time": 1.0, "x": 30.0, "z": 0.0}]})");
  const auto hips_x_at_1s = [&](const std::string& extra) {
    const fs::path out = work_dir() / "far.json.out";
    const RunResult r = run_cli("--model " + quote(model_dir()) + " --timeline " + quote(timeline.string()) +
                                " --seconds 2 --threads 1 --interpolate-root off --out-json " + quote(out.string()) +
                                extra);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const std::vector<unsigned char> bytes = ardy_test::read_bytes(out.string());
    const nlohmann::json doc = nlohmann::json::parse(bytes.begin(), bytes.end());
    return doc.at("frames")[20].at("positions")[0][0].get<double>();
  };
  CHECK(hips_x_at_1s(" --max-root-speed 0") == Catch::Approx(30.0).margin(1e-3));
  CHECK(hips_x_at_1s("") < 10.0);
  CHECK(hips_x_at_1s(" --max-root-speed 6") < 10.0);
  const RunResult bad = run_cli("--model " + quote(model_dir()) + " --timeline " + quote(timeline.string()) +
                                " --seconds 1 --max-root-speed -2");
  CHECK(bad.code == 2);
  CHECK_THAT(bad.err, ContainsSubstring("--max-root-speed"));
}

TEST_CASE("ardy-generate --text-only-guidance-scale scales w_text where only a prompt steers", "[cli]") {
  const auto hips_path = [&](const std::string& timeline_text, const std::string& extra) {
    const fs::path timeline = write_timeline("text_only.json", timeline_text);
    const fs::path out = work_dir() / "text_only.json.out";
    const RunResult r = run_cli("--model " + quote(model_dir()) + " --timeline " + quote(timeline.string()) +
                                " --seconds 2 --seed 4 --threads 1 --out-json " + quote(out.string()) + extra);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const std::vector<unsigned char> bytes = ardy_test::read_bytes(out.string());
    const nlohmann::json doc = nlohmann::json::parse(bytes.begin(), bytes.end());
    std::vector<double> hips;
    for (const auto& frame : doc.at("frames")) {
      for (int axis = 0; axis < 3; ++axis) hips.push_back(frame.at("positions")[0][axis].get<double>());
    }
    return hips;
  };
  const auto largest_gap = [](const std::vector<double>& a, const std::vector<double>& b) {
    REQUIRE(a.size() == b.size());
    double gap = 0.0;
    for (size_t i = 0; i < a.size(); ++i) gap = std::max(gap, std::fabs(a[i] - b[i]));
    return gap;
  };
  // Text alone, one step (in the upper half of the schedule, where the scale
  // applies): w_text 2 at scale 1.5 is w_text 3.
  const std::string text_only = R"({"prompts": [{"time": 0, "text": "walk"}]})";
  const std::vector<double> scaled = hips_path(text_only, " --steps 1 --w-text 2 --text-only-guidance-scale 1.5");
  CHECK(largest_gap(scaled, hips_path(text_only, " --steps 1 --w-text 3")) < 1e-5);
  CHECK(largest_gap(scaled, hips_path(text_only, " --steps 1 --w-text 2")) > 1e-4);
  // Four steps: the late two keep w_text 2.
  const std::vector<double> four = hips_path(text_only, " --w-text 2 --text-only-guidance-scale 1.5");
  CHECK(largest_gap(four, hips_path(text_only, " --w-text 3")) > 1e-4);
  CHECK(largest_gap(four, hips_path(text_only, " --w-text 2")) > 1e-4);
  // With a goal ahead of every window the scale changes nothing.
  const std::string with_goal = R"({"prompts": [{"time": 0, "text": "walk"}],
    "constraints": [{"type": "waypoint", "time": 1.9, "x": 1.0, "z": 0.5}]})";
  CHECK(largest_gap(hips_path(with_goal, " --text-only-guidance-scale 1.5"), hips_path(with_goal, "")) < 1e-9);
}

TEST_CASE("ardy-generate refuses bad arguments with exit code 2 and a message", "[cli][errors]") {
  const fs::path timeline = write_timeline("ok.json", R"({"prompts": [{"time": 0, "text": "walk"}]})");
  const std::string base = "--model " + quote(model_dir()) + " --timeline " + quote(timeline.string());
  RunResult r = run_cli("--timeline x.json --seconds 2");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("ardy-generate: missing --model") && ContainsSubstring("usage:"));
  r = run_cli(base + " --seconds abc");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--seconds is 'abc', expected a number"));
  r = run_cli(base + " --seconds 0");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--seconds must be positive"));
  r = run_cli(base + " --seconds 1 --bogus 3");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("unknown argument '--bogus'"));
  r = run_cli(base + " --seconds 1 --seed 1 --seed 2");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--seed is given more than once"));
  r = run_cli(base + " --seconds");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--seconds needs a value"));
  r = run_cli(base + " --seconds 1 --foot-lock maybe");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--foot-lock must be on or off, got 'maybe'"));
  r = run_cli(base + " --seconds 1 --path-guidance-scale 0");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--path-guidance-scale must be above 0, got 0"));
  r = run_cli(base + " --seconds 1 --path-guidance-scale 2");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--path-guidance-scale is '2', expected a number in 0..1"));
  r = run_cli(base + " --seconds 1 --text-only-guidance-scale 0");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--text-only-guidance-scale must be above 0, got 0"));
  r = run_cli(base + " --seconds 1 --text-only-guidance-scale 5");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, ContainsSubstring("--text-only-guidance-scale is '5', expected a number in 0..4"));
  r = run_cli("--help");
  CHECK(r.code == 0);
  CHECK_THAT(r.out, ContainsSubstring("usage: ardy-generate"));
}

TEST_CASE("ardy-generate reports bad models, timelines and settings with exit code 1", "[cli][errors]") {
  const fs::path ok = write_timeline("ok2.json", R"({"prompts": [{"time": 0, "text": "walk"}]})");
  RunResult r = run_cli("--model /nonexistent/model --timeline " + quote(ok.string()) + " --seconds 1");
  CHECK(r.code == 1);
  CHECK_THAT(r.err, ContainsSubstring("ardy-generate: error: /nonexistent/model: not a folder"));

  const std::string model = "--model " + quote(model_dir());
  r = run_cli(model + " --timeline /nonexistent.json --seconds 1");
  CHECK(r.code == 1);
  CHECK_THAT(r.err, ContainsSubstring("/nonexistent.json: file not found (expected a JSON timeline)"));

  const fs::path bad_joint =
      write_timeline("bad_joint.json",
                     R"({"constraints": [{"type": "joint", "time": 1, "joint": "RightHand", "position": [0, 1, 0]}]})");
  r = run_cli(model + " --timeline " + quote(bad_joint.string()) + " --seconds 1");
  CHECK(r.code == 1);
  CHECK_THAT(r.err, ContainsSubstring("constraints[0] (joint): skeleton: unknown joint 'RightHand' (the skeleton's "
                                      "joints are Hips"));

  const fs::path bad_field =
      write_timeline("bad_field.json", R"({"constraints": [{"type": "waypoint", "time": 1, "x": 0, "z": "far"}]})");
  r = run_cli(model + " --timeline " + quote(bad_field.string()) + " --seconds 1");
  CHECK(r.code == 1);
  CHECK_THAT(r.err, ContainsSubstring("constraints[0] (waypoint): z must be a number, found \"far\""));

  const fs::path long_prompt =
      write_timeline("long.json", R"({"prompts": [{"time": 0, "text": ")" + std::string(10000, 'w') + R"("}]})");
  r = run_cli(model + " --timeline " + quote(long_prompt.string()) + " --seconds 1");
  CHECK(r.code == 1);
  CHECK_THAT(r.err, ContainsSubstring("prompts[0]: text: prompt is 10000 characters long"));

  r = run_cli(model + " --timeline " + quote(ok.string()) + " --seconds 1 --steps 11");
  CHECK(r.code == 1);
  CHECK_THAT(r.err, ContainsSubstring("steps is 11, expected 1..10"));

  r = run_cli(model + " --timeline " + quote(ok.string()) + " --seconds 1 --out-bvh /nonexistent/dir/out.bvh");
  CHECK(r.code == 1);
  CHECK_THAT(r.err, ContainsSubstring("/nonexistent/dir/out.bvh: cannot open for writing"));
}
