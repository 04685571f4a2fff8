// The C ABI (ardy_c.h) over ModelPackage and Planner. Every entry point
// catches everything: no exception crosses the boundary. Messages go to the
// handle (or to a thread-local slot when there is no handle).

#define ARDY_C_BUILD 1
#include "ardy_c.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <new>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtc/quaternion.hpp>

#include "error.hpp"
#include "onnx_session.hpp"
#include "package.hpp"
#include "planner.hpp"
#include "window_batcher.hpp"

struct ardy_model {
  std::shared_ptr<const ardy::ModelPackage> package;
  mutable std::mutex mutex;
  mutable std::string error;
};

struct ardy_batcher {
  std::unique_ptr<ardy::WindowBatcher> batcher;
};

struct ardy_planner {
  std::shared_ptr<const ardy::ModelPackage> package;
  std::unique_ptr<ardy::Planner> planner;
  mutable std::mutex mutex;
  mutable std::string error;          // the last failing call's message
  mutable uint64_t worker_errors = 0;  // worker errors already older than `error`
  mutable std::string message;        // what ardy_planner_last_error returned
};

namespace {

thread_local std::string g_last_error;

struct Failure {
  ardy_status status;
  std::string message;
};

// Thrown inside this file for a failure whose status the boundary knows.
class StatusError : public std::runtime_error {
 public:
  StatusError(ardy_status status, const std::string& message) : std::runtime_error(message), status_(status) {}
  ardy_status status() const { return status_; }

 private:
  ardy_status status_;
};

// Runs `f`, turning every exception into a status and a message. An
// ardy::Error is reported with `error_status` (the caller knows what kind of
// input it was checking).
template <typename F>
Failure run_guarded(ardy_status error_status, F&& f) {
  try {
    return Failure{f(), std::string()};
  } catch (const StatusError& e) {
    return Failure{e.status(), e.what()};
  } catch (const ardy::Error& e) {
    return Failure{error_status, e.what()};
  } catch (const std::bad_alloc&) {
    return Failure{ARDY_ERROR_OUT_OF_MEMORY, "out of memory"};
  } catch (const std::exception& e) {
    return Failure{ARDY_ERROR_RUNTIME, e.what()};
  } catch (...) {
    return Failure{ARDY_ERROR_RUNTIME, "unknown failure in the ARDY runtime"};
  }
}

ardy_status fail_global(ardy_status status, const std::string& message) {
  try {
    g_last_error = message;
  } catch (...) {
  }
  return status;
}

ardy_status fail_planner(const ardy_planner* p, ardy_status status, const std::string& message) {
  try {
    const uint64_t seen = p->planner->stats().errors;
    std::lock_guard<std::mutex> lock(p->mutex);
    p->error = message;
    p->worker_errors = seen;
  } catch (...) {
  }
  return status;
}

ardy_status fail_model(const ardy_model* m, ardy_status status, const std::string& message) {
  try {
    std::lock_guard<std::mutex> lock(m->mutex);
    m->error = message;
  } catch (...) {
  }
  return status;
}

// A planner command: NULL handle -> thread-local message; ardy::Error ->
// invalid argument, message on the handle.
template <typename F>
ardy_status planner_call(const ardy_planner* p, const char* function, F&& f) {
  if (!p) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, std::string(function) + ": planner is NULL");
  Failure r = run_guarded(ARDY_ERROR_INVALID_ARGUMENT, [&] {
    f(*p->planner);
    return ARDY_OK;
  });
  if (r.status == ARDY_OK) return ARDY_OK;
  return fail_planner(p, r.status, r.message);
}

void set_id(uint64_t* out, uint64_t id) {
  if (out) *out = id;
}

[[noreturn]] void invalid(const std::string& message) { throw StatusError(ARDY_ERROR_INVALID_ARGUMENT, message); }

void require(bool ok, const std::string& message) {
  if (!ok) invalid(message);
}

std::string number_text(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+infinity" : "-infinity";
  std::ostringstream out;
  out << v;
  return out.str();
}

// Times of commands (planner seconds) are 0..1e7 s: a negative time is a
// caller's mistake, refused rather than taken as "now" (a time the playhead
// has already passed still means now). Speeds of steering up to 100 m/s and
// start positions within 1e6 m match constraints.hpp's bounds.
constexpr double kMaxTime = 1e7;
constexpr double kMaxSteeringSpeed = 100.0;
constexpr double kMaxCoordinate = 1e6;

void check_time(const char* function, const char* name, double t) {
  if (!(t >= 0.0 && t <= kMaxTime)) {
    invalid(std::string(function) + ": " + name + " is " + number_text(t) + " s, expected 0..1e7 s (planner seconds)");
  }
}

ardy::PackageOptions package_options(const ardy_model_params* params) {
  const ardy_model_params p = params ? *params : ardy_model_default_params();
  if (p.intra_op_threads < 0 || p.intra_op_threads > 1024) {
    invalid("ardy_model_params: intra_op_threads is " + std::to_string(p.intra_op_threads) + ", expected 0..1024");
  }
  if (p.max_prompt_chars == 0) invalid("ardy_model_params: max_prompt_chars must be at least 1");
  ardy::PackageOptions options;
  options.session.intra_op_threads = p.intra_op_threads;
  options.shared_thread_pool = p.fast_threads;
  options.session.allow_spinning = p.fast_threads;
  options.text.cache_capacity = p.text_cache_capacity;
  options.text.max_prompt_chars = p.max_prompt_chars;
  return options;
}

ardy_status make_model(ardy::ModelPackage package, ardy_model** out) {
  auto handle = std::make_unique<ardy_model>();
  handle->package = std::make_shared<const ardy::ModelPackage>(std::move(package));
  *out = handle.release();
  return ARDY_OK;
}

const char* c_string_or_empty(const std::string& s) { return s.c_str(); }

}  // namespace

extern "C" {

// --- library -----------------------------------------------------------------------

const char* ardy_version(void) { return "0.1.0"; }

int ardy_abi_version(void) { return ARDY_ABI_VERSION; }

const char* ardy_onnxruntime_version(void) {
  static const std::string version = [] {
    try {
      return ardy::OnnxEnvironment::runtime_version();
    } catch (...) {
      return std::string("unknown");
    }
  }();
  return version.c_str();
}

const char* ardy_status_name(ardy_status status) {
  switch (status) {
    case ARDY_OK: return "ARDY_OK";
    case ARDY_ERROR_INVALID_ARGUMENT: return "ARDY_ERROR_INVALID_ARGUMENT";
    case ARDY_ERROR_IO: return "ARDY_ERROR_IO";
    case ARDY_ERROR_INVALID_MODEL: return "ARDY_ERROR_INVALID_MODEL";
    case ARDY_ERROR_NOT_READY: return "ARDY_ERROR_NOT_READY";
    case ARDY_ERROR_BUFFER_TOO_SMALL: return "ARDY_ERROR_BUFFER_TOO_SMALL";
    case ARDY_ERROR_OUT_OF_MEMORY: return "ARDY_ERROR_OUT_OF_MEMORY";
    case ARDY_ERROR_RUNTIME: return "ARDY_ERROR_RUNTIME";
    case ARDY_ERROR_TIMEOUT: return "ARDY_ERROR_TIMEOUT";
  }
  return "ARDY_UNKNOWN_STATUS";
}

const char* ardy_last_error(void) { return g_last_error.c_str(); }

// --- model -----------------------------------------------------------------------------

ardy_model_params ardy_model_default_params(void) {
  ardy_model_params p;
  p.intra_op_threads = 0;
  p.text_cache_capacity = 256;
  p.max_prompt_chars = 2000;
  p.fast_threads = false;
  return p;
}

ardy_status ardy_model_load_from_folder(const char* path, const ardy_model_params* params, ardy_model** out) {
  if (!out) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_model_load_from_folder: out is NULL");
  *out = nullptr;
  if (!path) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_model_load_from_folder: path is NULL");
  Failure r = run_guarded(ARDY_ERROR_INVALID_MODEL, [&]() -> ardy_status {
    const std::string folder(path);
    std::error_code ec;
    if (!std::filesystem::exists(folder, ec)) {
      throw StatusError(ARDY_ERROR_IO, "'" + folder + "' does not exist (expected a model package folder with model.json)");
    }
    if (!std::filesystem::is_directory(folder, ec)) {
      throw StatusError(ARDY_ERROR_IO, "'" + folder + "' is not a folder (expected a model package folder with model.json)");
    }
    const std::string json = (std::filesystem::path(folder) / ardy::ModelPackage::kModelFile).string();
    if (!std::filesystem::is_regular_file(json, ec)) {
      throw StatusError(ARDY_ERROR_IO, "'" + folder + "' has no model.json (not a model package folder)");
    }
    return make_model(ardy::ModelPackage::from_folder(folder, package_options(params)), out);
  });
  if (r.status == ARDY_OK) return ARDY_OK;
  return fail_global(r.status, "ardy_model_load_from_folder: " + r.message);
}

ardy_status ardy_model_load_from_memory(const ardy_file_buffer* files, size_t file_count, const char* name,
                                        const ardy_model_params* params, ardy_model** out) {
  if (!out) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_model_load_from_memory: out is NULL");
  *out = nullptr;
  if (!files && file_count > 0) {
    return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_model_load_from_memory: files is NULL");
  }
  const std::string label = name ? name : "package";
  Failure r = run_guarded(ARDY_ERROR_INVALID_MODEL, [&]() -> ardy_status {
    ardy::PackageFileViews views;
    for (size_t i = 0; i < file_count; ++i) {
      const ardy_file_buffer& f = files[i];
      const std::string where = "files[" + std::to_string(i) + "]";
      if (!f.name) invalid(where + ".name is NULL");
      if (!f.data && f.size > 0) invalid(where + " ('" + f.name + "'): data is NULL");
      if (!views.emplace(f.name, ardy::ByteView{f.data, f.size}).second) invalid(where + ": '" + f.name + "' is given twice");
    }
    return make_model(ardy::ModelPackage::from_memory(views, label, package_options(params)), out);
  });
  if (r.status == ARDY_OK) return ARDY_OK;
  return fail_global(r.status, "ardy_model_load_from_memory: " + r.message);
}

void ardy_model_free(ardy_model* model) { delete model; }

const char* ardy_model_last_error(const ardy_model* model) {
  if (!model) return "";
  std::lock_guard<std::mutex> lock(model->mutex);
  return c_string_or_empty(model->error);
}

double ardy_model_fps(const ardy_model* model) { return model ? model->package->fps() : 0.0; }

double ardy_model_window_seconds(const ardy_model* model) {
  return model ? static_cast<double>(model->package->tokens().window_frames()) / model->package->fps() : 0.0;
}

size_t ardy_model_joint_count(const ardy_model* model) {
  return model ? model->package->skeleton().joint_count() : 0;
}

const char* ardy_model_joint_name(const ardy_model* model, size_t joint) {
  if (!model || joint >= model->package->skeleton().joint_count()) return nullptr;
  return model->package->skeleton().names()[joint].c_str();
}

int32_t ardy_model_joint_parent(const ardy_model* model, size_t joint) {
  if (!model || joint >= model->package->skeleton().joint_count()) return -1;
  return static_cast<int32_t>(model->package->skeleton().parents()[joint]);
}

int32_t ardy_model_joint_index(const ardy_model* model, const char* name) {
  if (!model || !name) return -1;
  const auto index = model->package->skeleton().find(name);
  return index ? static_cast<int32_t>(*index) : -1;
}

ardy_status ardy_model_joint_offset(const ardy_model* model, size_t joint, float* xyz) {
  if (!model) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_model_joint_offset: model is NULL");
  if (!xyz) return fail_model(model, ARDY_ERROR_INVALID_ARGUMENT, "ardy_model_joint_offset: xyz is NULL");
  const ardy::Skeleton& s = model->package->skeleton();
  if (joint >= s.joint_count()) {
    return fail_model(model, ARDY_ERROR_INVALID_ARGUMENT,
                      "ardy_model_joint_offset: joint " + std::to_string(joint) + " is out of range (the skeleton has " +
                          std::to_string(s.joint_count()) + " joints)");
  }
  const glm::vec3& o = s.offsets()[joint];
  xyz[0] = o.x;
  xyz[1] = o.y;
  xyz[2] = o.z;
  return ARDY_OK;
}

size_t ardy_model_contact_count(const ardy_model* model) {
  return model ? model->package->contact_joints().size() : 0;
}

const char* ardy_model_contact_name(const ardy_model* model, size_t contact) {
  if (!model || contact >= model->package->contact_joints().size()) return nullptr;
  return model->package->contact_joints()[contact].c_str();
}

size_t ardy_model_feature_size(const ardy_model* model) {
  return model ? model->package->layout().feature_size : 0;
}

// --- planner ---------------------------------------------------------------------------

ardy_planner_params ardy_planner_default_params(void) {
  const ardy::PlannerConfig c;
  ardy_planner_params p;
  p.steps = 0;
  p.w_text = NAN;
  p.w_con = NAN;
  p.path_guidance_scale = NAN;
  p.text_only_guidance_scale = NAN;
  p.history_seconds = c.history_seconds;
  p.future_seconds = -1.0;
  p.start_x = c.start_xz.x;
  p.start_z = c.start_xz.y;
  p.seed = c.seed;
  p.min_buffer_frames = static_cast<uint32_t>(c.min_buffer_frames);
  p.initial_latency_seconds = c.initial_latency_seconds;
  p.latency_margin = c.latency_margin;
  p.low_water_seconds = c.low_water_seconds;
  p.keep_behind_seconds = c.keep_behind_seconds;
  p.cancel_obsolete_windows = c.cancel_obsolete_windows;
  p.output_smoothing_frames = -1.0;
  p.interpolate_root = -1;
  p.max_root_speed = c.max_root_speed;
  p.foot_lock = c.foot_lock;
  p.batcher = nullptr;
  p.initial_history = nullptr;
  p.initial_history_frames = 0;
  return p;
}

ardy_batcher_params ardy_batcher_default_params(void) {
  const ardy::WindowBatcherConfig c;
  ardy_batcher_params p;
  p.gather_seconds = c.gather_seconds;
  p.max_windows = static_cast<uint32_t>(c.max_windows);
  return p;
}

ardy_status ardy_batcher_create(const ardy_batcher_params* params, ardy_batcher** out) {
  if (!out) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_batcher_create: out is NULL");
  *out = nullptr;
  Failure r = run_guarded(ARDY_ERROR_INVALID_ARGUMENT, [&]() -> ardy_status {
    const ardy_batcher_params p = params ? *params : ardy_batcher_default_params();
    auto handle = std::make_unique<ardy_batcher>();
    handle->batcher = std::make_unique<ardy::WindowBatcher>(ardy::WindowBatcherConfig{p.gather_seconds, p.max_windows});
    *out = handle.release();
    return ARDY_OK;
  });
  if (r.status == ARDY_OK) return ARDY_OK;
  return fail_global(r.status, "ardy_batcher_create: " + r.message);
}

void ardy_batcher_free(ardy_batcher* batcher) {
  try {
    delete batcher;
  } catch (...) {
  }
}

ardy_status ardy_batcher_get_stats(const ardy_batcher* batcher, ardy_batcher_stats* out) {
  if (!batcher) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_batcher_get_stats: batcher is NULL");
  if (!out) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_batcher_get_stats: out is NULL");
  const ardy::WindowBatcherStats s = batcher->batcher->stats();
  out->batches = s.batches;
  out->windows = s.windows;
  out->withdrawn = s.withdrawn;
  out->failed_batches = s.failed_batches;
  out->largest_batch = static_cast<uint32_t>(s.largest_batch);
  out->queued = static_cast<uint32_t>(s.queued);
  return ARDY_OK;
}

ardy_status ardy_planner_create(ardy_model* model, const ardy_planner_params* params, ardy_planner** out) {
  if (!out) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_create: out is NULL");
  *out = nullptr;
  if (!model) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_create: model is NULL");
  Failure r = run_guarded(ARDY_ERROR_INVALID_ARGUMENT, [&]() -> ardy_status {
    const ardy_planner_params p = params ? *params : ardy_planner_default_params();
    ardy::PlannerConfig c;
    if (p.steps < 0) invalid("ardy_planner_params: steps is " + std::to_string(p.steps) + ", expected 0 (default) or more");
    if (p.steps > 0) c.steps = static_cast<size_t>(p.steps);
    if (!std::isnan(p.w_text)) c.w_text = p.w_text;
    if (!std::isnan(p.w_con)) c.w_con = p.w_con;
    if (!std::isnan(p.path_guidance_scale)) {
      require(ardy::path_guidance_scale_in_range(p.path_guidance_scale),
              "ardy_planner_params: path_guidance_scale is " + number_text(p.path_guidance_scale) +
                  ", expected (0, 1] or NaN (the package default)");
      c.path_guidance_scale = p.path_guidance_scale;
    }
    if (!std::isnan(p.text_only_guidance_scale)) {
      require(ardy::text_only_guidance_scale_in_range(p.text_only_guidance_scale),
              "ardy_planner_params: text_only_guidance_scale is " + number_text(p.text_only_guidance_scale) +
                  ", expected (0, 4] or NaN (the package default)");
      c.text_only_guidance_scale = p.text_only_guidance_scale;
    }
    c.history_seconds = p.history_seconds;
    if (!(p.future_seconds < 0.0)) c.future_seconds = p.future_seconds;
    require(std::isfinite(p.start_x) && std::isfinite(p.start_z), "ardy_planner_params: start_x/start_z are not finite");
    require(std::fabs(p.start_x) <= kMaxCoordinate && std::fabs(p.start_z) <= kMaxCoordinate,
            "ardy_planner_params: start_x/start_z are (" + number_text(p.start_x) + ", " + number_text(p.start_z) +
                "), outside +-1e6 m (positions must lie within 1e6 m of the origin)");
    c.start_xz = glm::dvec2(p.start_x, p.start_z);
    c.seed = p.seed;
    c.min_buffer_frames = p.min_buffer_frames;
    c.initial_latency_seconds = p.initial_latency_seconds;
    c.latency_margin = p.latency_margin;
    c.low_water_seconds = p.low_water_seconds;
    c.keep_behind_seconds = p.keep_behind_seconds;
    c.cancel_obsolete_windows = p.cancel_obsolete_windows;
    if (!(p.output_smoothing_frames < 0.0)) c.output_smoothing_frames = p.output_smoothing_frames;
    if (p.interpolate_root < -1 || p.interpolate_root > 1) {
      invalid("ardy_planner_params: interpolate_root is " + std::to_string(p.interpolate_root) +
              ", expected -1 (the package's), 0 or 1");
    }
    if (p.interpolate_root >= 0) c.interpolate_root = p.interpolate_root == 1;
    c.max_root_speed = p.max_root_speed;
    c.foot_lock = p.foot_lock;
    if (p.batcher) c.generator = p.batcher->batcher->generator();
    if (p.initial_history_frames > 0) {
      require(p.initial_history != nullptr, "ardy_planner_params: initial_history is NULL but initial_history_frames is " +
                                                std::to_string(p.initial_history_frames));
      const size_t values = size_t{p.initial_history_frames} * model->package->layout().feature_size;
      c.initial_history.assign(p.initial_history, p.initial_history + values);
    }
    auto handle = std::make_unique<ardy_planner>();
    handle->package = model->package;
    handle->planner = std::make_unique<ardy::Planner>(model->package, std::move(c));
    *out = handle.release();
    return ARDY_OK;
  });
  if (r.status == ARDY_OK) return ARDY_OK;
  return fail_global(r.status, "ardy_planner_create: " + r.message);
}

void ardy_planner_free(ardy_planner* planner) {
  try {
    delete planner;
  } catch (...) {
  }
}

const char* ardy_planner_last_error(const ardy_planner* planner) {
  if (!planner) return "";
  try {
    const uint64_t worker = planner->planner->stats().errors;
    std::lock_guard<std::mutex> lock(planner->mutex);
    if (worker > planner->worker_errors) {
      planner->message = planner->planner->last_error();
    } else {
      planner->message = planner->error;
    }
    return planner->message.c_str();
  } catch (...) {
    return "";
  }
}

bool ardy_planner_pop_error(ardy_planner* planner, char* buffer, size_t capacity) {
  if (!planner || !buffer || capacity == 0) return false;
  try {
    std::string message;
    if (!planner->planner->pop_error(message)) return false;
    const size_t n = std::min(message.size(), capacity - 1);
    std::memcpy(buffer, message.data(), n);
    buffer[n] = '\0';
    return true;
  } catch (...) {
    return false;
  }
}

ardy_status ardy_planner_set_prompt(ardy_planner* planner, const char* text) {
  return planner_call(planner, "ardy_planner_set_prompt", [&](ardy::Planner& p) {
    if (text) {
      p.set_prompt(text);
    } else {
      p.clear_prompt();
    }
  });
}

ardy_status ardy_planner_set_prompt_at(ardy_planner* planner, double time, const char* text) {
  return planner_call(planner, "ardy_planner_set_prompt_at", [&](ardy::Planner& p) {
    check_time("set_prompt_at", "time", time);
    if (text) {
      p.set_prompt_at(time, text);
    } else {
      p.clear_prompt_at(time);
    }
  });
}

ardy_status ardy_planner_add_waypoint(ardy_planner* planner, double time, double x, double z, bool has_heading,
                                      double heading, uint64_t* out_id) {
  return planner_call(planner, "ardy_planner_add_waypoint", [&](ardy::Planner& p) {
    check_time("add_waypoint", "time", time);
    set_id(out_id, p.add_waypoint(time, x, z, has_heading ? std::optional<double>(heading) : std::nullopt));
  });
}

ardy_status ardy_planner_add_path(ardy_planner* planner, double start_time, const double* points_xz,
                                  size_t point_count, double speed, bool smooth, uint64_t* out_id) {
  return planner_call(planner, "ardy_planner_add_path", [&](ardy::Planner& p) {
    check_time("add_path", "start_time", start_time);
    require(points_xz || point_count == 0, "add_path: points_xz is NULL");
    require(point_count <= (size_t{1} << 20), "add_path: too many points");
    std::vector<glm::dvec2> points(point_count);
    for (size_t i = 0; i < point_count; ++i) points[i] = glm::dvec2(points_xz[2 * i], points_xz[2 * i + 1]);
    set_id(out_id, p.add_path(start_time, points, speed, smooth));
  });
}

ardy_status ardy_planner_add_path_frames(ardy_planner* planner, double start_time, const double* positions_xz,
                                         size_t frame_count, const double* headings, uint64_t* out_id) {
  return planner_call(planner, "ardy_planner_add_path_frames", [&](ardy::Planner& p) {
    check_time("add_path_frames", "start_time", start_time);
    require(positions_xz || frame_count == 0, "add_path_frames: positions_xz is NULL");
    require(frame_count <= (size_t{1} << 20), "add_path_frames: too many frames");
    std::vector<glm::dvec2> positions(frame_count);
    for (size_t i = 0; i < frame_count; ++i) positions[i] = glm::dvec2(positions_xz[2 * i], positions_xz[2 * i + 1]);
    std::vector<double> h;
    if (headings) h.assign(headings, headings + frame_count);
    set_id(out_id, p.add_path_frames(start_time, std::move(positions), std::move(h)));
  });
}

ardy_status ardy_planner_add_joint_target(ardy_planner* planner, double time, const char* joint,
                                          const double* position, const double* rotation_xyzw, const double* root_xz,
                                          uint64_t* out_id) {
  return planner_call(planner, "ardy_planner_add_joint_target", [&](ardy::Planner& p) {
    check_time("add_joint_target", "time", time);
    require(joint != nullptr, "add_joint_target: joint is NULL");
    ardy::JointTargetSpec spec;
    spec.time = time;
    spec.joint = joint;
    if (position) spec.position = glm::dvec3(position[0], position[1], position[2]);
    if (rotation_xyzw) spec.rotation = glm::dquat(rotation_xyzw[3], rotation_xyzw[0], rotation_xyzw[1], rotation_xyzw[2]);
    if (root_xz) spec.root_xz = glm::dvec2(root_xz[0], root_xz[1]);
    set_id(out_id, p.add_joint_target(spec));
  });
}

ardy_status ardy_planner_add_keyframe(ardy_planner* planner, double time, const float* root_position, float heading,
                                      const float* local_rotations_xyzw, size_t joint_count, bool include_root,
                                      uint64_t* out_id) {
  return planner_call(planner, "ardy_planner_add_keyframe", [&](ardy::Planner& p) {
    check_time("add_keyframe", "time", time);
    require(root_position != nullptr, "add_keyframe: root_position is NULL");
    require(local_rotations_xyzw != nullptr, "add_keyframe: local_rotations_xyzw is NULL");
    require(joint_count == p.joint_count(), "add_keyframe: joint_count is " + std::to_string(joint_count) +
                                                ", the model has " + std::to_string(p.joint_count()) + " joints");
    ardy::Pose pose;
    pose.root_position = glm::vec3(root_position[0], root_position[1], root_position[2]);
    pose.heading = heading;
    pose.local_rotations.resize(joint_count);
    for (size_t j = 0; j < joint_count; ++j) {
      const float* q = local_rotations_xyzw + 4 * j;
      pose.local_rotations[j] = glm::quat(q[3], q[0], q[1], q[2]);
    }
    set_id(out_id, p.add_keyframe_pose(time, pose, include_root));
  });
}

ardy_status ardy_planner_add_keyframe_features(ardy_planner* planner, double time, const double* features,
                                               size_t feature_count, bool include_root, uint64_t* out_id) {
  return planner_call(planner, "ardy_planner_add_keyframe_features", [&](ardy::Planner& p) {
    check_time("add_keyframe_features", "time", time);
    require(features || feature_count == 0, "add_keyframe_features: features is NULL");
    require(feature_count <= (size_t{1} << 20), "add_keyframe_features: too many features");
    set_id(out_id, p.add_keyframe(time, std::vector<double>(features, features + feature_count), include_root));
  });
}

ardy_status ardy_planner_add_contact(ardy_planner* planner, double start_time, double end_time,
                                     const char* const* feet, size_t foot_count, double value, uint64_t* out_id) {
  return planner_call(planner, "ardy_planner_add_contact", [&](ardy::Planner& p) {
    check_time("add_contact", "start_time", start_time);
    check_time("add_contact", "end_time", end_time);
    require(feet || foot_count == 0, "add_contact: feet is NULL");
    std::vector<std::string> names;
    for (size_t i = 0; i < foot_count; ++i) {
      require(feet[i] != nullptr, "add_contact: feet[" + std::to_string(i) + "] is NULL");
      names.emplace_back(feet[i]);
    }
    set_id(out_id, p.add_contact(start_time, end_time, names, value));
  });
}

ardy_status ardy_planner_remove_constraint(ardy_planner* planner, uint64_t id) {
  return planner_call(planner, "ardy_planner_remove_constraint", [&](ardy::Planner& p) { p.remove_constraint(id); });
}

ardy_status ardy_planner_clear_constraints(ardy_planner* planner) {
  return planner_call(planner, "ardy_planner_clear_constraints", [&](ardy::Planner& p) { p.clear_constraints(); });
}

ardy_status ardy_planner_set_target_velocity(ardy_planner* planner, double vx, double vz) {
  return planner_call(planner, "ardy_planner_set_target_velocity",
                      [&](ardy::Planner& p) {
                        // NaN and infinity: the planner's own message names the component.
                        if (std::isfinite(vx) && std::isfinite(vz)) {
                          require(std::hypot(vx, vz) <= kMaxSteeringSpeed,
                                  "set_target_velocity: (" + number_text(vx) + ", " + number_text(vz) +
                                      ") m/s is faster than the 100 m/s allowed");
                        }
                        p.set_target_velocity(vx, vz);
                      });
}

ardy_status ardy_planner_clear_target_velocity(ardy_planner* planner) {
  return planner_call(planner, "ardy_planner_clear_target_velocity",
                      [&](ardy::Planner& p) { p.clear_target_velocity(); });
}

ardy_status ardy_planner_set_sampling(ardy_planner* planner, int32_t steps, float w_text, float w_con,
                                      float path_guidance_scale, float text_only_guidance_scale) {
  return planner_call(planner, "ardy_planner_set_sampling", [&](ardy::Planner& p) {
    require(steps >= 0, "set_sampling: steps is " + std::to_string(steps) + ", expected 0 (unchanged) or more");
    p.set_sampling(steps > 0 ? std::optional<size_t>(static_cast<size_t>(steps)) : std::nullopt,
                   std::isnan(w_text) ? std::nullopt : std::optional<float>(w_text),
                   std::isnan(w_con) ? std::nullopt : std::optional<float>(w_con),
                   std::isnan(path_guidance_scale) ? std::nullopt : std::optional<float>(path_guidance_scale),
                   std::isnan(text_only_guidance_scale) ? std::nullopt : std::optional<float>(text_only_guidance_scale));
  });
}

// --- playback ------------------------------------------------------------------------------

ardy_status ardy_planner_advance(ardy_planner* planner, double delta) {
  return planner_call(planner, "ardy_planner_advance", [&](ardy::Planner& p) { p.advance(delta); });
}

double ardy_planner_time(const ardy_planner* planner) { return planner ? planner->planner->time() : 0.0; }

double ardy_planner_queued_seconds(const ardy_planner* planner) {
  return planner ? planner->planner->queued_seconds() : 0.0;
}

ardy_status ardy_planner_sample(const ardy_planner* planner, double time, ardy_pose_info* info,
                                float* local_rotations_xyzw, float* world_positions_xyz, float* contacts,
                                size_t joint_capacity, size_t contact_capacity) {
  if (!planner) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_sample: planner is NULL");
  const ardy::Planner& p = *planner->planner;
  const size_t joints = p.joint_count();
  const size_t feet = planner->package->layout().contact_count();
  if ((local_rotations_xyzw || world_positions_xyz) && joint_capacity < joints) {
    return fail_planner(planner, ARDY_ERROR_BUFFER_TOO_SMALL,
                        "ardy_planner_sample: the arrays hold " + std::to_string(joint_capacity) +
                            " joints, the model has " + std::to_string(joints));
  }
  if (contacts && contact_capacity < feet) {
    return fail_planner(planner, ARDY_ERROR_BUFFER_TOO_SMALL,
                        "ardy_planner_sample: contacts holds " + std::to_string(contact_capacity) +
                            " flags, the model has " + std::to_string(feet));
  }
  if (std::isnan(time)) {
    return fail_planner(planner, ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_sample: time is NaN");
  }
  // One scratch pose per thread: allocated on a thread's first call only.
  thread_local ardy::Pose pose;
  bool ok = false;
  Failure r = run_guarded(ARDY_ERROR_RUNTIME, [&] {
    ok = p.sample(time, pose);
    return ARDY_OK;
  });
  if (r.status != ARDY_OK) return fail_planner(planner, r.status, "ardy_planner_sample: " + r.message);
  if (!ok) return fail_planner(planner, ARDY_ERROR_NOT_READY, "ardy_planner_sample: no motion has been generated yet");
  if (info) {
    info->time = pose.time;
    info->root_position[0] = pose.root_position.x;
    info->root_position[1] = pose.root_position.y;
    info->root_position[2] = pose.root_position.z;
    info->heading = pose.heading;
    info->window_id = pose.window_id;
  }
  for (size_t j = 0; j < joints; ++j) {
    if (local_rotations_xyzw) {
      const glm::quat& q = pose.local_rotations[j];
      local_rotations_xyzw[4 * j + 0] = q.x;
      local_rotations_xyzw[4 * j + 1] = q.y;
      local_rotations_xyzw[4 * j + 2] = q.z;
      local_rotations_xyzw[4 * j + 3] = q.w;
    }
    if (world_positions_xyz) {
      world_positions_xyz[3 * j + 0] = pose.positions[j].x;
      world_positions_xyz[3 * j + 1] = pose.positions[j].y;
      world_positions_xyz[3 * j + 2] = pose.positions[j].z;
    }
  }
  if (contacts) std::copy(pose.contacts.begin(), pose.contacts.end(), contacts);
  return ARDY_OK;
}

ardy_status ardy_planner_sample_current(const ardy_planner* planner, ardy_pose_info* info,
                                        float* local_rotations_xyzw, float* world_positions_xyz, float* contacts,
                                        size_t joint_capacity, size_t contact_capacity) {
  if (!planner) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_sample_current: planner is NULL");
  return ardy_planner_sample(planner, planner->planner->time(), info, local_rotations_xyzw, world_positions_xyz,
                             contacts, joint_capacity, contact_capacity);
}

ardy_status ardy_planner_get_stats(const ardy_planner* planner, ardy_planner_stats* out) {
  if (!planner) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_get_stats: planner is NULL");
  if (!out) return fail_planner(planner, ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_get_stats: out is NULL");
  Failure r = run_guarded(ARDY_ERROR_RUNTIME, [&] {
    const ardy::PlannerStats s = planner->planner->stats();
    out->windows_started = s.windows_started;
    out->windows_published = s.windows_published;
    out->splices = s.splices;
    out->late_windows = s.late_windows;
    out->cancelled_windows = s.cancelled_windows;
    out->failed_windows = s.failed_windows;
    out->commands = s.commands;
    out->errors = s.errors;
    out->last_latency_seconds = s.last_latency_seconds;
    out->latency_estimate_seconds = s.latency_estimate_seconds;
    out->buffer_frames = s.buffer_frames;
    out->underrun_seconds = s.underrun_seconds;
    out->playhead = s.playhead;
    out->queued_seconds = s.queued_seconds;
    out->window_in_flight = s.window_in_flight;
    return ARDY_OK;
  });
  if (r.status != ARDY_OK) return fail_planner(planner, r.status, "ardy_planner_get_stats: " + r.message);
  return ARDY_OK;
}

ardy_status ardy_planner_wait_idle(ardy_planner* planner, double timeout_seconds) {
  if (!planner) return fail_global(ARDY_ERROR_INVALID_ARGUMENT, "ardy_planner_wait_idle: planner is NULL");
  if (!std::isfinite(timeout_seconds) || timeout_seconds < 0.0) {
    return fail_planner(planner, ARDY_ERROR_INVALID_ARGUMENT,
                        "ardy_planner_wait_idle: timeout_seconds must be finite and >= 0");
  }
  Failure r = run_guarded(ARDY_ERROR_RUNTIME, [&] {
    return planner->planner->wait_idle(timeout_seconds) ? ARDY_OK : ARDY_ERROR_TIMEOUT;
  });
  if (r.status == ARDY_ERROR_TIMEOUT) {
    return fail_planner(planner, r.status, "ardy_planner_wait_idle: the planner was still busy after the timeout");
  }
  if (r.status != ARDY_OK) return fail_planner(planner, r.status, "ardy_planner_wait_idle: " + r.message);
  return ARDY_OK;
}

}  // extern "C"
