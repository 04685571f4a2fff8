/* ardy_c.h: the ARDY runtime's C ABI (the native bridge).
 *
 * For engines and languages outside Godot: C, C# (P/Invoke), anything with a
 * C FFI. Plain C types only; opaque handles; every function returns an
 * ardy_status or a plain value, and no C++ exception ever crosses this
 * boundary.
 *
 *   ardy_model_params mp = ardy_model_default_params();
 *   ardy_model* model = NULL;
 *   if (ardy_model_load_from_folder("models/default", &mp, &model) != ARDY_OK)
 *     fprintf(stderr, "%s\n", ardy_last_error());
 *   ardy_planner_params pp = ardy_planner_default_params();
 *   ardy_planner* planner = NULL;
 *   ardy_planner_create(model, &pp, &planner);
 *   ardy_planner_set_prompt(planner, "a person walks forward");
 *   // every frame:
 *   ardy_planner_advance(planner, delta_seconds);
 *   ardy_planner_sample_current(planner, &info, rotations_xyzw, positions_xyz, NULL, joints, 0);
 *   ...
 *   ardy_planner_free(planner);
 *   ardy_model_free(model);
 *
 * Errors. A failing call returns a status other than ARDY_OK and leaves the
 * object as it was (usable). Its message, which says what was wrong and
 * where, is returned by ardy_planner_last_error / ardy_model_last_error for
 * calls on a handle, and by ardy_last_error (thread-local) for calls that
 * have no handle yet (loading, creating) or were given a NULL handle. Errors
 * of the planner's worker thread (a window that failed) are queued:
 * ardy_planner_pop_error.
 *
 * Threads. A model may be shared by several planners and threads. A
 * planner's functions are thread-safe; advance/sample never wait on
 * inference and never allocate. Returned strings stay valid until the next
 * call that sets a message on the same handle (or, for ardy_last_error, the
 * next failing call on the same thread); copy them.
 *
 * Units: seconds (planner time: played motion, frame f at f / fps), metres,
 * radians; world space, Y up; heading 0 faces +Z. Quaternions are x, y, z, w.
 * Bounds: numbers that parse but are no motion are refused with
 * ARDY_ERROR_INVALID_ARGUMENT, never used: command times 0..1e7 s (a time the
 * playhead has passed still means now), positions within 1e6 m of the origin
 * per axis, headings within +-1e6 rad, path and steering speeds up to
 * 100 m/s, contact values 0..1, NaN and infinities anywhere.
 *
 * C# P/Invoke: bool is one byte here (C99 _Bool): marshal it as
 * [MarshalAs(UnmanagedType.I1)] in signatures and structs; the structs are
 * plain sequential layouts; strings are UTF-8 (char*).
 */
#ifndef ARDY_C_H
#define ARDY_C_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32)
#if defined(ARDY_C_BUILD)
#define ARDY_API __declspec(dllexport)
#else
#define ARDY_API __declspec(dllimport)
#endif
#elif defined(__GNUC__)
#define ARDY_API __attribute__((visibility("default")))
#else
#define ARDY_API
#endif

#define ARDY_VERSION_MAJOR 0
#define ARDY_VERSION_MINOR 1
#define ARDY_VERSION_PATCH 0
/* Changes whenever a struct layout or a signature of this header changes. */
#define ARDY_ABI_VERSION 4

typedef struct ardy_model ardy_model;     /* a loaded model package (immutable) */
typedef struct ardy_planner ardy_planner; /* one character's streaming planner */
typedef struct ardy_batcher ardy_batcher; /* runs several planners' windows as one batch */

typedef enum ardy_status {
  ARDY_OK = 0,
  ARDY_ERROR_INVALID_ARGUMENT = 1, /* NULL pointer, NaN/inf, out of range, bad prompt, unknown joint */
  ARDY_ERROR_IO = 2,               /* a file or folder is missing or unreadable */
  ARDY_ERROR_INVALID_MODEL = 3,    /* the model package is malformed (message names the field) */
  ARDY_ERROR_NOT_READY = 4,        /* no motion has been generated yet */
  ARDY_ERROR_BUFFER_TOO_SMALL = 5, /* a caller-provided array is too small */
  ARDY_ERROR_OUT_OF_MEMORY = 6,
  ARDY_ERROR_RUNTIME = 7,          /* inference or another failure inside the runtime */
  ARDY_ERROR_TIMEOUT = 8
} ardy_status;

/* --- library ------------------------------------------------------------- */

ARDY_API const char* ardy_version(void);        /* "0.1.0" */
ARDY_API int ardy_abi_version(void);            /* ARDY_ABI_VERSION of the built library */
ARDY_API const char* ardy_onnxruntime_version(void);
ARDY_API const char* ardy_status_name(ardy_status status); /* "ARDY_ERROR_IO", ... */
/* The message of this thread's last failing call that had no handle to keep
 * it (load, create, or a NULL handle); "" if none. */
ARDY_API const char* ardy_last_error(void);

/* --- model ----------------------------------------------------------------- */

typedef struct ardy_model_params {
  int32_t intra_op_threads;      /* ONNX Runtime threads per graph call; 0: all cores but one (at least 1) */
  uint32_t text_cache_capacity;  /* prompt embeddings cached; 0 turns the cache off (default 256) */
  uint32_t max_prompt_chars;     /* longer prompts are refused (default 2000) */
  /* One intra-op pool for all of the model's graphs whose idle threads spin:
   * a window takes about 28 % less time (2 cores, shipped model) for about
   * 0.03 more cores of CPU while a planner streams (default false: a pool
   * per graph, idle threads sleep). ONNX Runtime keeps one environment per
   * process, created by the first model loaded: load this one first. */
  bool fast_threads;
} ardy_model_params;

ARDY_API ardy_model_params ardy_model_default_params(void);

/* One package file given as bytes (e.g. read from an engine's packed
 * archive). name is the file name model.json uses ("model.json",
 * "denoiser.onnx", "vocab.txt", ...). The bytes need not outlive the call. */
typedef struct ardy_file_buffer {
  const char* name;
  const void* data;
  size_t size;
} ardy_file_buffer;

/* params may be NULL (defaults). On failure *out is NULL and ardy_last_error
 * names the path or the field. */
ARDY_API ardy_status ardy_model_load_from_folder(const char* path, const ardy_model_params* params,
                                                 ardy_model** out);
ARDY_API ardy_status ardy_model_load_from_memory(const ardy_file_buffer* files, size_t file_count, const char* name,
                                                 const ardy_model_params* params, ardy_model** out);
/* Safe with NULL. Planners created from the model keep it alive. */
ARDY_API void ardy_model_free(ardy_model* model);
ARDY_API const char* ardy_model_last_error(const ardy_model* model);

ARDY_API double ardy_model_fps(const ardy_model* model);            /* 0 for NULL */
ARDY_API double ardy_model_window_seconds(const ardy_model* model); /* one window of generated motion */
ARDY_API size_t ardy_model_joint_count(const ardy_model* model);
ARDY_API const char* ardy_model_joint_name(const ardy_model* model, size_t joint); /* NULL out of range */
ARDY_API int32_t ardy_model_joint_parent(const ardy_model* model, size_t joint);   /* -1: root or out of range */
ARDY_API int32_t ardy_model_joint_index(const ardy_model* model, const char* name); /* -1: unknown */
/* Rest offset of a joint in its parent's frame (xyz, metres). */
ARDY_API ardy_status ardy_model_joint_offset(const ardy_model* model, size_t joint, float* xyz);
ARDY_API size_t ardy_model_contact_count(const ardy_model* model);
ARDY_API const char* ardy_model_contact_name(const ardy_model* model, size_t contact);
ARDY_API size_t ardy_model_feature_size(const ardy_model* model); /* M, for keyframes given as features */

/* --- planner --------------------------------------------------------------- */

typedef struct ardy_planner_params {
  int32_t steps;                  /* diffusion steps per window; 0: the package default */
  float w_text;                   /* text guidance; NaN: the package default */
  float w_con;                    /* constraint guidance; NaN: the package default */
  float path_guidance_scale;      /* w_con times this where the goals are a dense root path alone (keyboard
                                   * steering, clicked paths), in (0, 1]; NaN: the package default */
  float text_only_guidance_scale; /* w_text times this where a window has a prompt and no goals, at the
                                   * steps in the upper half of the diffusion schedule, in (0, 4];
                                   * NaN: the package default */
  double history_seconds;         /* history window (default 8; clamped to the package's maximum) */
  double future_seconds;          /* out-of-window goal horizon; < 0: the package's maximum */
  double start_x, start_z;        /* where the character starts */
  uint64_t seed;                  /* noise of the windows */
  uint32_t min_buffer_frames;     /* the replan buffer is at least this many frames */
  double initial_latency_seconds; /* assumed before the first window is measured (default 0.1) */
  double latency_margin;          /* factor on the measured latency (default 1.25) */
  double low_water_seconds;       /* append a window when less is queued ahead (default 1) */
  double keep_behind_seconds;     /* frames kept behind the playhead (default 1) */
  bool cancel_obsolete_windows;   /* cancel an appended window a new command would replace (default true) */
  double output_smoothing_frames; /* output filter sigma in frames; < 0: the package's (default); 0: off */
  int32_t interpolate_root;       /* sparse root targets become paths: -1 the package's (default), 0 off, 1 on */
  double max_root_speed;          /* root goals never ask for more (m/s; default 6; 0: no limit) */
  bool foot_lock;                 /* planted feet held in place by leg IK on the output (default true) */
  ardy_batcher* batcher;          /* NULL (default): the planner runs its own windows; else they go to this batcher */
  /* What the character was doing before (an animation it played, a pose held
   * for a few frames): world explicit features [initial_history_frames,
   * ardy_model_feature_size], the last frame just before time 0; the first
   * window continues it. Frames: a multiple of the model's patch size (4).
   * NULL / 0 (default): start from nothing at (start_x, start_z). Copied. */
  const float* initial_history;
  uint32_t initial_history_frames;
} ardy_planner_params;

ARDY_API ardy_planner_params ardy_planner_default_params(void);

/* --- batcher: several characters, one denoiser call per step ------------------ */

/* Planners created with the same batcher (ardy_planner_params.batcher) hand
 * their windows to its one inference thread, which runs the windows that
 * arrive within gather_seconds of each other (same model, same step count) as
 * one batch: far cheaper per character than one after the other. A planner
 * keeps working if its batcher is freed first, but its windows then fail
 * ("the window batcher is gone"). */
typedef struct ardy_batcher_params {
  double gather_seconds; /* wait this long after a batch's first window for others (default 0.002) */
  uint32_t max_windows;  /* windows per batch; a full batch starts at once (default 16) */
} ardy_batcher_params;

typedef struct ardy_batcher_stats {
  uint64_t batches;
  uint64_t windows;       /* windows run in a batch */
  uint64_t withdrawn;     /* windows whose planner stopped waiting (cancelled) */
  uint64_t failed_batches;
  uint32_t largest_batch;
  uint32_t queued;        /* windows waiting for a batch now */
} ardy_batcher_stats;

ARDY_API ardy_batcher_params ardy_batcher_default_params(void);
/* params may be NULL. On failure *out is NULL and ardy_last_error says why. */
ARDY_API ardy_status ardy_batcher_create(const ardy_batcher_params* params, ardy_batcher** out);
/* Waits for the batch in flight; NULL is ignored. */
ARDY_API void ardy_batcher_free(ardy_batcher* batcher);
ARDY_API ardy_status ardy_batcher_get_stats(const ardy_batcher* batcher, ardy_batcher_stats* out);
/* params may be NULL. Starts the planner's worker thread; the first window is
 * generated at once. */
ARDY_API ardy_status ardy_planner_create(ardy_model* model, const ardy_planner_params* params, ardy_planner** out);
/* Cancels a window in flight (returns within one model call), joins the
 * worker and frees everything. Safe with NULL. */
ARDY_API void ardy_planner_free(ardy_planner* planner);
/* The message of this handle's last failing call; else the latest worker
 * error; "" if none. */
ARDY_API const char* ardy_planner_last_error(const ardy_planner* planner);
/* Pops the oldest queued worker error into buffer (truncated, NUL-terminated).
 * Returns false when the queue is empty (buffer untouched). */
ARDY_API bool ardy_planner_pop_error(ardy_planner* planner, char* buffer, size_t capacity);

/* Prompts (UTF-8). text NULL clears the prompt. set_prompt takes effect after
 * the replan buffer; set_prompt_at at the first token boundary at or after
 * `time` (a past time means now). */
ARDY_API ardy_status ardy_planner_set_prompt(ardy_planner* planner, const char* text);
ARDY_API ardy_status ardy_planner_set_prompt_at(ardy_planner* planner, double time, const char* text);

/* Constraints; times in planner seconds. *out_id (may be NULL) receives an id
 * for ardy_planner_remove_constraint. */
ARDY_API ardy_status ardy_planner_add_waypoint(ardy_planner* planner, double time, double x, double z,
                                               bool has_heading, double heading, uint64_t* out_id);
/* A path at `speed` m/s through point_count (x, z) points (2 doubles each);
 * smooth: mouse-style clicks, interpolated then smoothed. */
ARDY_API ardy_status ardy_planner_add_path(ardy_planner* planner, double start_time, const double* points_xz,
                                           size_t point_count, double speed, bool smooth, uint64_t* out_id);
/* One (x, z) per model frame from start_time; headings NULL or one per frame. */
ARDY_API ardy_status ardy_planner_add_path_frames(ardy_planner* planner, double start_time, const double* positions_xz,
                                                  size_t frame_count, const double* headings, uint64_t* out_id);
/* position (xyz) and/or rotation (world, xyzw) of a joint; either may be NULL,
 * not both. Non-root position: relative to the root's ground projection,
 * or world space when root_xz (2 doubles) is given. */
ARDY_API ardy_status ardy_planner_add_joint_target(ardy_planner* planner, double time, const char* joint,
                                                   const double* position, const double* rotation_xyzw,
                                                   const double* root_xz, uint64_t* out_id);
/* A full-body keyframe from a pose: root position (xyz), heading, and the
 * local rotations of every joint (joint_count * 4 floats, xyzw). */
ARDY_API ardy_status ardy_planner_add_keyframe(ardy_planner* planner, double time, const float* root_position,
                                               float heading, const float* local_rotations_xyzw, size_t joint_count,
                                               bool include_root, uint64_t* out_id);
/* A full-body keyframe as world explicit features (ardy_model_feature_size values). */
ARDY_API ardy_status ardy_planner_add_keyframe_features(ardy_planner* planner, double time, const double* features,
                                                        size_t feature_count, bool include_root, uint64_t* out_id);
/* Foot contacts over [start_time, end_time); feet by contact joint name
 * (ardy_model_contact_name); feet NULL / foot_count 0: all of them. */
ARDY_API ardy_status ardy_planner_add_contact(ardy_planner* planner, double start_time, double end_time,
                                              const char* const* feet, size_t foot_count, double value,
                                              uint64_t* out_id);
ARDY_API ardy_status ardy_planner_remove_constraint(ardy_planner* planner, uint64_t id);
ARDY_API ardy_status ardy_planner_clear_constraints(ardy_planner* planner);

/* Keyboard steering: target root velocity (m/s, world x and z). */
ARDY_API ardy_status ardy_planner_set_target_velocity(ardy_planner* planner, double vx, double vz);
ARDY_API ardy_status ardy_planner_clear_target_velocity(ardy_planner* planner);
/* Sampling of the windows to come: steps 0, a NaN value: unchanged
 * (path_guidance_scale, text_only_guidance_scale: ardy_planner_params). */
ARDY_API ardy_status ardy_planner_set_sampling(ardy_planner* planner, int32_t steps, float w_text, float w_con,
                                               float path_guidance_scale, float text_only_guidance_scale);

/* --- playback (never waits on inference, never allocates) ------------------ */

/* Moves the playhead by delta seconds (finite, >= 0), at most to the last
 * generated frame. */
ARDY_API ardy_status ardy_planner_advance(ardy_planner* planner, double delta);
ARDY_API double ardy_planner_time(const ardy_planner* planner);           /* the playhead, seconds */
ARDY_API double ardy_planner_queued_seconds(const ardy_planner* planner); /* generated motion ahead */

typedef struct ardy_pose_info {
  double time;             /* the time sampled (clamped to the frames kept) */
  float root_position[3];  /* world */
  float heading;           /* radians about +Y */
  uint64_t window_id;      /* the window the (earlier) frame came from */
} ardy_pose_info;

/* The pose at `time`, interpolated between model frames, into caller arrays:
 * local_rotations_xyzw [joint_capacity * 4] (parent-relative; root: world),
 * world_positions_xyz [joint_capacity * 3], contacts [contact_capacity].
 * Any of info and the arrays may be NULL (skipped). ARDY_ERROR_NOT_READY
 * before the first window; ARDY_ERROR_BUFFER_TOO_SMALL when a given array
 * holds fewer than ardy_model_joint_count joints / contact_count flags. */
ARDY_API ardy_status ardy_planner_sample(const ardy_planner* planner, double time, ardy_pose_info* info,
                                         float* local_rotations_xyzw, float* world_positions_xyz, float* contacts,
                                         size_t joint_capacity, size_t contact_capacity);
ARDY_API ardy_status ardy_planner_sample_current(const ardy_planner* planner, ardy_pose_info* info,
                                                 float* local_rotations_xyzw, float* world_positions_xyz,
                                                 float* contacts, size_t joint_capacity, size_t contact_capacity);

typedef struct ardy_planner_stats {
  uint64_t windows_started;
  uint64_t windows_published;
  uint64_t splices;
  uint64_t late_windows;
  uint64_t cancelled_windows;
  uint64_t failed_windows;
  uint64_t commands;
  uint64_t errors;
  double last_latency_seconds;
  double latency_estimate_seconds;
  int64_t buffer_frames;
  double underrun_seconds;
  double playhead;
  double queued_seconds;
  bool window_in_flight;
} ardy_planner_stats;

ARDY_API ardy_status ardy_planner_get_stats(const ardy_planner* planner, ardy_planner_stats* out);
/* Blocks until the worker has nothing left to do (ARDY_ERROR_TIMEOUT after
 * timeout_seconds). For tools, baking and tests; never from a frame loop. */
ARDY_API ardy_status ardy_planner_wait_idle(ardy_planner* planner, double timeout_seconds);

#ifdef __cplusplus
}
#endif

#endif /* ARDY_C_H */
