// The C ABI (src/ardy_c.h) with the strings and arrays a caller passes: the
// input is a script of calls (FuzzedDataProvider) on one planner of the tiny
// package: prompts, every kind of constraint with arrays of fuzzed lengths and
// numbers (NaN, infinity, 1e300, negative times among them), joint and foot
// names, sampling, playback, model queries, and loading from memory buffers
// with fuzzed names and bytes. Checked: no call crashes or leaks an exception
// (c_api.cpp catches all), every status is a known one, and every failure
// leaves a message naming what was wrong.
//
// The planner's windows go to a batcher freed right after the planner is
// made, so they fail at once instead of running inference: the fuzzer
// exercises the command paths, not the model.

#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "ardy_c.h"
#include "fuzz_common.hpp"

namespace {

ardy_model* model() {
  static ardy_model* m = [] {
    ardy_model_params params = ardy_model_default_params();
    params.intra_op_threads = 1;
    ardy_model* out = nullptr;
    if (ardy_model_load_from_folder(ardy_fuzz::data_path("tiny_package").c_str(), &params, &out) != ARDY_OK) {
      ardy_fuzz::broken(std::string("the tiny package does not load: ") + ardy_last_error());
    }
    return out;
  }();
  return m;
}

class Script {
 public:
  Script(const uint8_t* data, size_t size) : in_(data, size) {}

  bool more() { return in_.remaining_bytes() > 0; }
  uint8_t op() { return in_.ConsumeIntegral<uint8_t>(); }
  bool flag() { return in_.ConsumeBool(); }
  size_t count(size_t most) { return in_.ConsumeIntegralInRange<size_t>(0, most); }
  int32_t int32() { return in_.ConsumeIntegral<int32_t>(); }
  uint64_t uint64() { return in_.ConsumeIntegral<uint64_t>(); }

  // Ordinary values, the edges the runtime must refuse, or any bit pattern.
  double number() {
    static const double kSpecial[] = {0.0,    -0.0,  1.0,     -5.0,   0.5,    1e300,   -1e300,  1e30,
                                      1e6,    -1e7,  1e7 + 1, 3e-310, 6.0,    1e-30,   std::numeric_limits<double>::quiet_NaN(),
                                      std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    switch (in_.ConsumeIntegralInRange<int>(0, 3)) {
      case 0: return kSpecial[in_.ConsumeIntegralInRange<size_t>(0, std::size(kSpecial) - 1)];
      case 1: {
        double v;
        const uint64_t bits = in_.ConsumeIntegral<uint64_t>();
        std::memcpy(&v, &bits, sizeof v);
        return v;
      }
      default: return in_.ConsumeFloatingPointInRange<double>(-10.0, 10.0);
    }
  }
  float number_f() { return static_cast<float>(number()); }
  std::vector<double> numbers(size_t n) {
    std::vector<double> out(n);
    for (double& v : out) v = number();
    return out;
  }
  std::string text(size_t most = 64) { return in_.ConsumeRandomLengthString(most); }
  std::vector<uint8_t> bytes(size_t most) { return in_.ConsumeBytes<uint8_t>(count(most)); }

 private:
  FuzzedDataProvider in_;
};

// A failing call must say why.
void check(ardy_status status, const char* message) {
  if (status < ARDY_OK || status > ARDY_ERROR_TIMEOUT) ardy_fuzz::broken("unknown status " + std::to_string(status));
  if (status != ARDY_OK && (message == nullptr || message[0] == '\0')) {
    ardy_fuzz::broken(std::string("a failing call (") + ardy_status_name(status) + ") left no message");
  }
}

void load_from_memory(Script& s) {
  const char* const kNames[] = {"model.json",   "history.onnx",      "goals.onnx", "denoiser.onnx",
                                "decoder.onnx", "text_encoder.onnx", "vocab.txt",  "encoder.onnx"};
  const size_t n = s.count(8);
  std::vector<std::string> names(n);
  std::vector<std::vector<uint8_t>> data(n);
  std::vector<ardy_file_buffer> files(n);
  for (size_t i = 0; i < n; ++i) {
    names[i] = s.flag() ? kNames[s.count(std::size(kNames) - 1)] : s.text(24);
    data[i] = s.bytes(4096);
    files[i].name = s.flag() && i == 0 ? nullptr : names[i].c_str();
    files[i].data = data[i].empty() ? nullptr : data[i].data();
    files[i].size = data[i].size();
  }
  ardy_model* out = nullptr;
  const std::string name = s.text(16);
  const ardy_status status = ardy_model_load_from_memory(files.data(), n, s.flag() ? nullptr : name.c_str(), nullptr, &out);
  check(status, ardy_last_error());
  ardy_model_free(out);
}

void planner_call(Script& s, ardy_planner* p, uint8_t op, std::vector<uint64_t>& ids) {
  ardy_model* m = model();
  const size_t joints = ardy_model_joint_count(m);
  uint64_t id = 0;
  ardy_status status = ARDY_OK;
  switch (op % 18) {
    case 0: {
      const std::string t = s.text(256);
      status = ardy_planner_set_prompt(p, s.flag() ? nullptr : t.c_str());
      break;
    }
    case 1: {
      const double time = s.number();
      const std::string t = s.text(256);
      status = ardy_planner_set_prompt_at(p, time, s.flag() ? nullptr : t.c_str());
      break;
    }
    case 2: {
      const double time = s.number(), x = s.number(), z = s.number();
      const bool has_heading = s.flag();
      status = ardy_planner_add_waypoint(p, time, x, z, has_heading, s.number(), &id);
      break;
    }
    case 3: {
      const size_t n = s.count(16);
      const std::vector<double> points = s.numbers(2 * n);
      const double time = s.number(), speed = s.number();
      status = ardy_planner_add_path(p, time, n ? points.data() : nullptr, n, speed, s.flag(), &id);
      break;
    }
    case 4: {
      const size_t n = s.count(64);
      const std::vector<double> positions = s.numbers(2 * n);
      const std::vector<double> headings = s.numbers(n);
      const bool with_headings = s.flag();
      status = ardy_planner_add_path_frames(p, s.number(), n ? positions.data() : nullptr, n,
                                            with_headings && n ? headings.data() : nullptr, &id);
      break;
    }
    case 5: {
      const std::string joint = s.flag() ? std::string(ardy_model_joint_name(m, s.count(joints - 1))) : s.text(24);
      const std::vector<double> position = s.numbers(3), rotation = s.numbers(4), root = s.numbers(2);
      const bool with_position = s.flag(), with_rotation = s.flag(), with_root = s.flag(), null_joint = s.flag() && s.flag();
      status = ardy_planner_add_joint_target(p, s.number(), null_joint ? nullptr : joint.c_str(),
                                             with_position ? position.data() : nullptr,
                                             with_rotation ? rotation.data() : nullptr,
                                             with_root ? root.data() : nullptr, &id);
      break;
    }
    case 6: {
      const size_t n = s.flag() ? joints : s.count(2 * joints);
      std::vector<float> rotations(4 * n);
      for (float& v : rotations) v = s.flag() ? s.number_f() : 0.5f;
      const float root[3] = {s.number_f(), s.number_f(), s.number_f()};
      const float heading = s.number_f();
      status = ardy_planner_add_keyframe(p, s.number(), root, heading, n ? rotations.data() : nullptr, n, s.flag(), &id);
      break;
    }
    case 7: {
      const size_t n = s.flag() ? ardy_model_feature_size(m) : s.count(300);
      std::vector<double> features(n);
      for (double& v : features) v = s.flag() ? s.number() : 0.1;
      status = ardy_planner_add_keyframe_features(p, s.number(), n ? features.data() : nullptr, n, s.flag(), &id);
      break;
    }
    case 8: {
      const size_t n = s.count(6);
      std::vector<std::string> names(n);
      std::vector<const char*> feet(n);
      for (size_t i = 0; i < n; ++i) {
        const char* known = ardy_model_contact_name(m, s.count(ardy_model_contact_count(m)));  // may be NULL
        names[i] = known && s.flag() ? std::string(known) : s.text(16);
        feet[i] = s.flag() && s.flag() ? nullptr : names[i].c_str();
      }
      const double start = s.number(), end = s.number();
      status = ardy_planner_add_contact(p, start, end, n ? feet.data() : nullptr, n, s.number(), &id);
      break;
    }
    case 9:
      status = ardy_planner_remove_constraint(p, ids.empty() || s.flag() ? s.uint64() : ids[s.count(ids.size() - 1)]);
      break;
    case 10: status = ardy_planner_clear_constraints(p); break;
    case 11: {
      const double vx = s.number(), vz = s.number();
      status = s.flag() ? ardy_planner_set_target_velocity(p, vx, vz) : ardy_planner_clear_target_velocity(p);
      break;
    }
    case 12: {
      const int32_t steps = s.int32();
      const float w_text = s.number_f(), w_con = s.number_f(), path_guidance_scale = s.number_f();
      const float text_only_guidance_scale = s.number_f();
      status = ardy_planner_set_sampling(p, steps, w_text, w_con, path_guidance_scale, text_only_guidance_scale);
      break;
    }
    case 13: status = ardy_planner_advance(p, s.number()); break;
    case 14: {
      const size_t jc = s.count(2 * joints), cc = s.count(8);
      std::vector<float> rotations(4 * jc), positions(3 * jc), contacts(cc);
      ardy_pose_info info;
      const double time = s.number();
      status = ardy_planner_sample(p, time, s.flag() ? &info : nullptr, jc ? rotations.data() : nullptr,
                                   jc && s.flag() ? positions.data() : nullptr, cc ? contacts.data() : nullptr, jc, cc);
      if (status == ARDY_ERROR_NOT_READY) status = ARDY_OK;  // expected: no window ever arrives
      break;
    }
    case 15: {
      // What a C caller passes: the text up to its first NUL.
      const std::string name = s.text(32).c_str();
      const int32_t index = ardy_model_joint_index(m, name.c_str());
      if (index >= 0 && name != ardy_model_joint_name(m, static_cast<size_t>(index))) {
        ardy_fuzz::broken("joint_index and joint_name disagree for '" + name + "'");
      }
      float xyz[3];
      const size_t joint = s.count(2 * joints);
      const ardy_status offset = ardy_model_joint_offset(m, joint, s.flag() ? xyz : nullptr);
      check(offset, ardy_model_last_error(m));
      if (offset == ARDY_OK && joint >= joints) ardy_fuzz::broken("an offset for a joint out of range");
      ardy_model_contact_name(m, s.count(8));
      ardy_model_joint_parent(m, s.count(2 * joints));
      return;
    }
    case 16: load_from_memory(s); return;
    case 17: {
      char buffer[16];
      ardy_planner_pop_error(p, buffer, s.count(sizeof buffer));
      ardy_planner_stats stats;
      check(ardy_planner_get_stats(p, &stats), ardy_planner_last_error(p));
      return;
    }
  }
  check(status, ardy_planner_last_error(p));
  if (status == ARDY_OK && id != 0) ids.push_back(id);
}

}  // namespace

// ONNX Runtime allocates some things once per process, on the first session
// of a kind (kept until exit, freed then: a run of one input reports no
// leak). libFuzzer's per-input leak check would take them for a leak of the
// input that came first, so make them here: the tiny package from memory with
// default settings, and a planner on the folder-loaded model.
extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  const char* const kFiles[] = {"model.json",   "history.onnx", "goals.onnx",        "denoiser.onnx",
                                "decoder.onnx", "encoder.onnx", "text_encoder.onnx", "vocab.txt"};
  std::vector<std::string> bytes;
  std::vector<ardy_file_buffer> files;
  for (const char* name : kFiles) bytes.push_back(ardy_fuzz::read_bytes(ardy_fuzz::data_path("tiny_package/") + name));
  for (size_t i = 0; i < bytes.size(); ++i) files.push_back({kFiles[i], bytes[i].data(), bytes[i].size()});
  ardy_model* warm = nullptr;
  if (ardy_model_load_from_memory(files.data(), files.size(), "warm-up", nullptr, &warm) != ARDY_OK) {
    ardy_fuzz::broken(std::string("the tiny package does not load from memory: ") + ardy_last_error());
  }
  ardy_model_free(warm);
  ardy_planner* planner = nullptr;
  const ardy_planner_params params = ardy_planner_default_params();
  if (ardy_planner_create(model(), &params, &planner) == ARDY_OK) ardy_planner_free(planner);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Script s(data, size);
  ardy_model* m = model();
  ardy_batcher* batcher = nullptr;
  check(ardy_batcher_create(nullptr, &batcher), ardy_last_error());
  ardy_planner_params params = ardy_planner_default_params();
  params.batcher = batcher;
  if (s.flag()) {
    params.start_x = s.number();
    params.start_z = s.number();
    params.history_seconds = s.number();
    params.max_root_speed = s.number();
  }
  ardy_planner* planner = nullptr;
  const ardy_status created = ardy_planner_create(m, &params, &planner);
  ardy_batcher_free(batcher);  // the planner's windows now fail at once, without inference
  check(created, ardy_last_error());
  if (created != ARDY_OK) return 0;
  std::vector<uint64_t> ids;
  for (int calls = 0; calls < 64 && s.more(); ++calls) planner_call(s, planner, s.op(), ids);
  ardy_planner_free(planner);
  return 0;
}
