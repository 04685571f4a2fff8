/* The C ABI (src/ardy_c.h) from C11 against libardy_c and the tiny test
 * package: library queries, loading from a folder and from memory buffers,
 * the planner's commands and playback, and the error paths (bad paths, NULL
 * arguments, NaN, bad prompts, unknown joints, small buffers). */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ardy_c.h"

#ifndef ARDY_TEST_DATA_DIR
#error "ARDY_TEST_DATA_DIR must be defined by the build"
#endif

static int g_checks = 0;
static int g_failures = 0;

#define CHECK(cond)                                                   \
  do {                                                                \
    ++g_checks;                                                       \
    if (!(cond)) {                                                    \
      ++g_failures;                                                   \
      fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
    }                                                                 \
  } while (0)

#define CHECK_STATUS(expr, expected)                                                         \
  do {                                                                                       \
    ardy_status s_ = (expr);                                                                 \
    ++g_checks;                                                                              \
    if (s_ != (expected)) {                                                                  \
      ++g_failures;                                                                          \
      fprintf(stderr, "%s:%d: %s returned %s, expected %s\n", __FILE__, __LINE__, #expr,     \
              ardy_status_name(s_), ardy_status_name(expected));                              \
    }                                                                                        \
  } while (0)

#define CHECK_CONTAINS(text, part)                                                                  \
  do {                                                                                              \
    const char* t_ = (text);                                                                        \
    ++g_checks;                                                                                     \
    if (!t_ || !strstr(t_, (part))) {                                                               \
      ++g_failures;                                                                                 \
      fprintf(stderr, "%s:%d: \"%s\" does not contain \"%s\"\n", __FILE__, __LINE__, t_ ? t_ : "(null)", (part)); \
    }                                                                                               \
  } while (0)

#define TINY ARDY_TEST_DATA_DIR "/tiny_package"

static void* read_file(const char* path, size_t* size) {
  FILE* f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  void* data = malloc(n > 0 ? (size_t)n : 1);
  if (data && n > 0 && fread(data, 1, (size_t)n, f) != (size_t)n) {
    free(data);
    data = NULL;
  }
  fclose(f);
  *size = (size_t)n;
  return data;
}

static void test_library(void) {
  CHECK(strcmp(ardy_version(), "0.1.0") == 0);
  CHECK(ardy_abi_version() == ARDY_ABI_VERSION);
  CHECK(strlen(ardy_onnxruntime_version()) > 0);
  CHECK(strcmp(ardy_status_name(ARDY_ERROR_IO), "ARDY_ERROR_IO") == 0);
  CHECK(strcmp(ardy_status_name((ardy_status)999), "ARDY_UNKNOWN_STATUS") == 0);
}

static void test_load_errors(void) {
  ardy_model* model = (ardy_model*)1;
  CHECK_STATUS(ardy_model_load_from_folder("/no/such/ardy_package", NULL, &model), ARDY_ERROR_IO);
  CHECK(model == NULL);
  CHECK_CONTAINS(ardy_last_error(), "/no/such/ardy_package");
  CHECK_CONTAINS(ardy_last_error(), "does not exist");
  CHECK_STATUS(ardy_model_load_from_folder(ARDY_TEST_DATA_DIR, NULL, &model), ARDY_ERROR_IO);
  CHECK_CONTAINS(ardy_last_error(), "no model.json");
  CHECK_STATUS(ardy_model_load_from_folder(NULL, NULL, &model), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "path is NULL");
  CHECK_STATUS(ardy_model_load_from_folder(TINY, NULL, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "out is NULL");
  ardy_model_params bad = ardy_model_default_params();
  bad.intra_op_threads = -3;
  CHECK_STATUS(ardy_model_load_from_folder(TINY, &bad, &model), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "intra_op_threads is -3");
  /* Memory: a package without its graphs. */
  size_t size = 0;
  void* json = read_file(TINY "/model.json", &size);
  CHECK(json != NULL);
  ardy_file_buffer only_json = {"model.json", json, size};
  CHECK_STATUS(ardy_model_load_from_memory(&only_json, 1, "partial", NULL, &model), ARDY_ERROR_INVALID_MODEL);
  CHECK_CONTAINS(ardy_last_error(), "partial");
  CHECK_CONTAINS(ardy_last_error(), ".onnx");
  ardy_file_buffer twice[2] = {{"model.json", json, size}, {"model.json", json, size}};
  CHECK_STATUS(ardy_model_load_from_memory(twice, 2, "twice", NULL, &model), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "given twice");
  CHECK_STATUS(ardy_model_load_from_memory(NULL, 3, "x", NULL, &model), ARDY_ERROR_INVALID_ARGUMENT);
  free(json);
  ardy_model_free(NULL); /* no-op */
}

static ardy_model* load_from_memory(void) {
  static const char* names[] = {"model.json",   "history.onnx", "goals.onnx",        "denoiser.onnx",
                                "decoder.onnx", "encoder.onnx", "text_encoder.onnx", "vocab.txt"};
  ardy_file_buffer files[8];
  void* data[8];
  char path[1024];
  for (int i = 0; i < 8; ++i) {
    snprintf(path, sizeof path, "%s/%s", TINY, names[i]);
    data[i] = read_file(path, &files[i].size);
    CHECK(data[i] != NULL);
    files[i].name = names[i];
    files[i].data = data[i];
  }
  ardy_model_params params = ardy_model_default_params();
  params.intra_op_threads = 1;
  ardy_model* model = NULL;
  CHECK_STATUS(ardy_model_load_from_memory(files, 8, "tiny (memory)", &params, &model), ARDY_OK);
  for (int i = 0; i < 8; ++i) free(data[i]); /* the bytes need not outlive the call */
  return model;
}

static void test_model_queries(const ardy_model* model) {
  CHECK(ardy_model_fps(model) == 20.0);
  CHECK(ardy_model_window_seconds(model) == 2.0);
  CHECK(ardy_model_joint_count(model) == 21);
  CHECK(strcmp(ardy_model_joint_name(model, 0), "Hips") == 0);
  CHECK(strcmp(ardy_model_joint_name(model, 12), "Hand_R") == 0);
  CHECK(ardy_model_joint_name(model, 21) == NULL);
  CHECK(ardy_model_joint_parent(model, 0) == -1);
  CHECK(ardy_model_joint_parent(model, 1) == 0);
  CHECK(ardy_model_joint_index(model, "Hand_R") == 12);
  CHECK(ardy_model_joint_index(model, "Hand") == -1);
  CHECK(ardy_model_joint_index(model, NULL) == -1);
  float offset[3];
  CHECK_STATUS(ardy_model_joint_offset(model, 1, offset), ARDY_OK);
  CHECK(isfinite(offset[1]));
  CHECK_STATUS(ardy_model_joint_offset(model, 99, offset), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_model_last_error(model), "joint 99 is out of range");
  CHECK(ardy_model_contact_count(model) == 4);
  CHECK(strcmp(ardy_model_contact_name(model, 0), "Foot_L") == 0);
  CHECK(ardy_model_contact_name(model, 4) == NULL);
  CHECK(ardy_model_feature_size(model) == 258);
  CHECK(ardy_model_joint_count(NULL) == 0);
  CHECK(ardy_model_fps(NULL) == 0.0);
}

static void test_planner(ardy_model* model) {
  enum { J = 21, C = 4 };
  float rotations[J * 4], positions[J * 3], contacts[C];
  ardy_pose_info info;
  ardy_planner* planner = NULL;

  ardy_planner_params params = ardy_planner_default_params();
  CHECK(params.history_seconds == 8.0);
  CHECK(isnan(params.w_text));
  params.history_seconds = -1.0;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK(planner == NULL);
  CHECK_CONTAINS(ardy_last_error(), "history_seconds");
  CHECK_STATUS(ardy_planner_create(NULL, NULL, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "model is NULL");
  params = ardy_planner_default_params();
  CHECK(params.output_smoothing_frames < 0.0 && params.interpolate_root == -1 && params.max_root_speed == 6.0);
  CHECK(params.foot_lock);
  params.output_smoothing_frames = 50.0;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "output_smoothing_frames is 50");
  params = ardy_planner_default_params();
  params.start_x = 1e300;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "start_x/start_z are (1e+300, 0), outside +-1e6 m");
  params = ardy_planner_default_params();
  CHECK(isnan(params.path_guidance_scale));
  params.path_guidance_scale = 0.0f;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "path_guidance_scale is 0, expected (0, 1] or NaN (the package default)");
  params = ardy_planner_default_params();
  CHECK(isnan(params.text_only_guidance_scale));
  params.text_only_guidance_scale = 5.0f;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "text_only_guidance_scale is 5, expected (0, 4] or NaN (the package default)");
  params = ardy_planner_default_params();
  params.interpolate_root = 2;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "interpolate_root is 2");
  params = ardy_planner_default_params();
  params.initial_history_frames = 8;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "initial_history is NULL");
  float history[6 * 512];
  memset(history, 0, sizeof history);
  params.initial_history = history;
  params.initial_history_frames = 6;
  CHECK(ardy_model_feature_size(model) <= 512);
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "multiple of the patch size");
  {
    /* A pose held for 8 frames at x = 2 (root position first, then the heading). */
    float held[8 * 512];
    const size_t m = ardy_model_feature_size(model);
    memset(held, 0, sizeof held);
    for (size_t f = 0; f < 8; ++f) {
      held[f * m + 0] = 2.0f;
      held[f * m + 1] = 0.9f;
      held[f * m + 3] = 1.0f;
    }
    params.initial_history = held;
    params.initial_history_frames = 8;
    CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_OK);
    CHECK_STATUS(ardy_planner_wait_idle(planner, 60.0), ARDY_OK);
    ardy_pose_info at_2, at_102;
    CHECK_STATUS(ardy_planner_sample(planner, 0.5, &at_2, NULL, NULL, NULL, 0, 0), ARDY_OK);
    ardy_planner_free(planner);
    /* The same pose 100 m further: the model sees the same (re-centred) history. */
    for (size_t f = 0; f < 8; ++f) held[f * m + 0] = 102.0f;
    CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_OK);
    CHECK_STATUS(ardy_planner_wait_idle(planner, 60.0), ARDY_OK);
    CHECK_STATUS(ardy_planner_sample(planner, 0.5, &at_102, NULL, NULL, NULL, 0, 0), ARDY_OK);
    CHECK(fabsf(at_102.root_position[0] - at_2.root_position[0] - 100.0f) < 1e-3f);
    CHECK(fabsf(at_102.root_position[2] - at_2.root_position[2]) < 1e-3f);
    ardy_planner_free(planner);
    planner = NULL;
  }
  params = ardy_planner_default_params();
  params.max_root_speed = -1.0;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "max_root_speed is -1");
  CHECK(planner == NULL);

  params = ardy_planner_default_params();
  params.start_x = 1.0;
  params.seed = 7;
  CHECK_STATUS(ardy_planner_create(model, &params, &planner), ARDY_OK);
  CHECK_STATUS(ardy_planner_wait_idle(planner, 60.0), ARDY_OK);
  CHECK(strcmp(ardy_planner_last_error(planner), "") == 0);

  /* Playback. */
  CHECK_STATUS(ardy_planner_sample_current(planner, &info, rotations, positions, contacts, J, C), ARDY_OK);
  for (int j = 0; j < J; ++j) {
    const float* q = rotations + 4 * j;
    CHECK(fabsf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0f) < 1e-4f);
  }
  CHECK(info.root_position[0] == positions[0] && info.root_position[2] == positions[2]);
  CHECK(info.window_id == 1);
  CHECK_STATUS(ardy_planner_sample(planner, 0.33, &info, NULL, NULL, NULL, 0, 0), ARDY_OK);
  CHECK(fabs(info.time - 0.33) < 1e-9);
  CHECK_STATUS(ardy_planner_sample(planner, 0.0, NULL, rotations, NULL, NULL, J - 1, 0), ARDY_ERROR_BUFFER_TOO_SMALL);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "hold 20 joints, the model has 21");
  CHECK_STATUS(ardy_planner_sample(planner, 0.0, NULL, NULL, NULL, contacts, 0, 2), ARDY_ERROR_BUFFER_TOO_SMALL);
  CHECK_STATUS(ardy_planner_sample(planner, NAN, &info, NULL, NULL, NULL, 0, 0), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(ardy_planner_advance(planner, 0.5), ARDY_OK);
  CHECK(fabs(ardy_planner_time(planner) - 0.5) < 1e-12);
  CHECK(ardy_planner_queued_seconds(planner) > 1.0);
  CHECK_STATUS(ardy_planner_advance(planner, NAN), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "advance: delta is NaN");
  CHECK_STATUS(ardy_planner_advance(planner, -1.0), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK(fabs(ardy_planner_time(planner) - 0.5) < 1e-12);

  /* Prompts. */
  CHECK_STATUS(ardy_planner_set_prompt(planner, "a person walks forward"), ARDY_OK);
  CHECK_STATUS(ardy_planner_set_prompt_at(planner, 3.0, "a person runs"), ARDY_OK);
  CHECK_STATUS(ardy_planner_set_prompt(planner, ""), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "prompt is empty");
  {
    char* long_prompt = malloc(10001);
    memset(long_prompt, 'a', 10000);
    long_prompt[10000] = '\0';
    CHECK_STATUS(ardy_planner_set_prompt(planner, long_prompt), ARDY_ERROR_INVALID_ARGUMENT);
    CHECK_CONTAINS(ardy_planner_last_error(planner), "10000 characters");
    free(long_prompt);
  }
  CHECK_STATUS(ardy_planner_set_prompt_at(planner, INFINITY, "a person runs"), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(ardy_planner_set_prompt_at(planner, 5.0, NULL), ARDY_OK); /* no prompt from 5 s on */

  /* Constraints. */
  uint64_t id = 0, id2 = 0;
  CHECK_STATUS(ardy_planner_add_waypoint(planner, 2.0, 1.0, 2.0, true, 0.5, &id), ARDY_OK);
  CHECK(id > 0);
  CHECK_STATUS(ardy_planner_add_waypoint(planner, 2.0, NAN, 2.0, false, 0.0, &id2), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "x is NaN");
  const double points[] = {0.0, 0.0, 1.0, 0.0, 1.0, 1.0};
  CHECK_STATUS(ardy_planner_add_path(planner, 1.0, points, 3, 1.2, true, &id2), ARDY_OK);
  CHECK(id2 > id);
  CHECK_STATUS(ardy_planner_add_path(planner, 1.0, points, 1, 1.2, false, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(ardy_planner_add_path(planner, 1.0, NULL, 3, 1.2, false, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  const double frames[] = {0.0, 0.0, 0.05, 0.0, 0.1, 0.0};
  const double headings[] = {1.5, 1.5, 1.5};
  CHECK_STATUS(ardy_planner_add_path_frames(planner, 1.5, frames, 3, headings, NULL), ARDY_OK);
  const double hand[] = {0.3, 1.4, 0.2};
  const double identity[] = {0.0, 0.0, 0.0, 1.0};
  const double root_xz[] = {0.0, 1.0};
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, "Hand_R", hand, NULL, NULL, NULL), ARDY_OK);
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, "Head", NULL, identity, NULL, NULL), ARDY_OK);
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, "Hand_L", hand, identity, root_xz, NULL), ARDY_OK);
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, "Hand", hand, NULL, NULL, NULL),
               ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "unknown joint 'Hand'");
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, NULL, hand, NULL, NULL, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, "Hand_R", NULL, NULL, NULL, NULL),
               ARDY_ERROR_INVALID_ARGUMENT);
  const double nan_position[] = {0.0, NAN, 0.0};
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, "Hand_R", nan_position, NULL, NULL, NULL),
               ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "position.y is NaN");
  /* A keyframe from the pose just sampled. */
  CHECK_STATUS(ardy_planner_sample(planner, 0.5, &info, rotations, NULL, NULL, J, 0), ARDY_OK);
  CHECK_STATUS(ardy_planner_add_keyframe(planner, 2.5, info.root_position, info.heading, rotations, J, true, NULL),
               ARDY_OK);
  CHECK_STATUS(ardy_planner_add_keyframe(planner, 2.5, info.root_position, info.heading, rotations, J - 1, true, NULL),
               ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "joint_count is 20");
  double features[258];
  for (int i = 0; i < 258; ++i) features[i] = 0.0;
  CHECK_STATUS(ardy_planner_add_keyframe_features(planner, 2.5, features, 258, false, NULL), ARDY_OK);
  CHECK_STATUS(ardy_planner_add_keyframe_features(planner, 2.5, features, 3, false, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "features has 3 values, expected 258");
  features[7] = NAN;
  CHECK_STATUS(ardy_planner_add_keyframe_features(planner, 2.5, features, 258, false, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "features[7] is NaN");
  const char* feet[] = {"Foot_L", "Toes_L"};
  CHECK_STATUS(ardy_planner_add_contact(planner, 1.0, 2.0, feet, 2, 1.0, NULL), ARDY_OK);
  CHECK_STATUS(ardy_planner_add_contact(planner, 1.0, 2.0, NULL, 0, 0.0, NULL), ARDY_OK);
  const char* bad_feet[] = {"Foot_X"};
  CHECK_STATUS(ardy_planner_add_contact(planner, 1.0, 2.0, bad_feet, 1, 1.0, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "unknown foot 'Foot_X'");
  CHECK_STATUS(ardy_planner_remove_constraint(planner, id), ARDY_OK);
  CHECK_STATUS(ardy_planner_remove_constraint(planner, 123456), ARDY_OK); /* unknown ids are ignored */
  CHECK_STATUS(ardy_planner_set_target_velocity(planner, 1.0, 0.5), ARDY_OK);
  CHECK_STATUS(ardy_planner_set_target_velocity(planner, INFINITY, 0.5), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "vx is inf");
  CHECK_STATUS(ardy_planner_set_sampling(planner, 99, NAN, NAN, NAN, NAN), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "steps is 99");
  CHECK_STATUS(ardy_planner_set_sampling(planner, 0, NAN, NAN, 1.5f, NAN), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "path_guidance_scale is 1.5, expected (0, 1]");
  CHECK_STATUS(ardy_planner_set_sampling(planner, 0, NAN, NAN, NAN, -1.0f), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "text_only_guidance_scale is -1, expected (0, 4]");
  CHECK_STATUS(ardy_planner_set_sampling(planner, 2, 1.5f, NAN, 0.5f, 1.5f), ARDY_OK);
  CHECK_STATUS(ardy_planner_wait_idle(planner, 60.0), ARDY_OK);

  /* Numbers that parse but are no motion: refused with the bound, never used. */
  CHECK_STATUS(ardy_planner_add_waypoint(planner, -5.0, 0.0, 0.0, false, 0.0, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "add_waypoint: time is -5 s, expected 0..1e7 s (planner seconds)");
  CHECK_STATUS(ardy_planner_add_waypoint(planner, NAN, 0.0, 0.0, false, 0.0, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "add_waypoint: time is NaN s");
  CHECK_STATUS(ardy_planner_add_waypoint(planner, 1.0, 1e300, 0.0, false, 0.0, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "x is 1e+300, outside +-1e+06 m");
  CHECK_STATUS(ardy_planner_add_waypoint(planner, 1.0, 0.0, 0.0, true, INFINITY, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "heading is +infinity");
  const double line[] = {0.0, 0.0, 0.0, 2.0};
  CHECK_STATUS(ardy_planner_add_path(planner, 1.0, line, 2, 1e30, false, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "speed is 1e+30, expected a positive finite speed up to 100 m/s");
  CHECK_STATUS(ardy_planner_add_path_frames(planner, INFINITY, line, 2, NULL, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "add_path_frames: start_time is +infinity s");
  CHECK_STATUS(ardy_planner_add_contact(planner, 1.0, 1e8, NULL, 0, 1.0, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "add_contact: end_time is 1e+08 s");
  CHECK_STATUS(ardy_planner_add_contact(planner, 1.0, 2.0, NULL, 0, NAN, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "value is NaN");
  CHECK_STATUS(ardy_planner_set_prompt_at(planner, -1.0, "a person walks"), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "set_prompt_at: time is -1 s");
  CHECK_STATUS(ardy_planner_set_target_velocity(planner, 1e30, 0.0), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "faster than the 100 m/s allowed");
  const double far_position[] = {0.0, 1e7, 0.0};
  CHECK_STATUS(ardy_planner_add_joint_target(planner, 1.5, "Hand_R", far_position, NULL, NULL, NULL),
               ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_planner_last_error(planner), "position.y is 1e+07, outside +-1e+06 m");

  /* Play on: the planner is still usable after all those errors. */
  for (int i = 0; i < 40; ++i) {
    CHECK_STATUS(ardy_planner_advance(planner, 0.1), ARDY_OK);
    CHECK_STATUS(ardy_planner_sample_current(planner, &info, rotations, positions, contacts, J, C), ARDY_OK);
    CHECK(isfinite(positions[3 * 12 + 1]));
    CHECK_STATUS(ardy_planner_wait_idle(planner, 60.0), ARDY_OK);
  }
  CHECK(fabs(ardy_planner_time(planner) - 4.5) < 1e-9);
  CHECK_STATUS(ardy_planner_clear_target_velocity(planner), ARDY_OK);
  CHECK_STATUS(ardy_planner_clear_constraints(planner), ARDY_OK);
  CHECK_STATUS(ardy_planner_set_prompt(planner, NULL), ARDY_OK);
  CHECK_STATUS(ardy_planner_wait_idle(planner, 60.0), ARDY_OK);

  ardy_planner_stats stats;
  CHECK_STATUS(ardy_planner_get_stats(planner, &stats), ARDY_OK);
  CHECK(stats.windows_published >= 3);
  CHECK(stats.splices >= 1);
  CHECK(stats.errors == 0);
  CHECK(stats.commands >= 20);
  CHECK(fabs(stats.playhead - 4.5) < 1e-9);
  CHECK(!stats.window_in_flight);
  CHECK_STATUS(ardy_planner_get_stats(planner, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  char message[256];
  CHECK(!ardy_planner_pop_error(planner, message, sizeof message));
  CHECK_STATUS(ardy_planner_wait_idle(planner, NAN), ARDY_ERROR_INVALID_ARGUMENT);

  /* NULL handles: a status and the thread-local message, never a crash. */
  CHECK_STATUS(ardy_planner_set_prompt(NULL, "a person walks"), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_CONTAINS(ardy_last_error(), "ardy_planner_set_prompt: planner is NULL");
  CHECK_STATUS(ardy_planner_advance(NULL, 0.1), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(ardy_planner_sample_current(NULL, &info, NULL, NULL, NULL, 0, 0), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(ardy_planner_add_waypoint(NULL, 1.0, 0.0, 0.0, false, 0.0, NULL), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK(ardy_planner_time(NULL) == 0.0);
  CHECK(strcmp(ardy_planner_last_error(NULL), "") == 0);
  CHECK(!ardy_planner_pop_error(NULL, message, sizeof message));

  /* Freed while a window may be in flight: returns within one model call. */
  CHECK_STATUS(ardy_planner_set_prompt(planner, "a person turns around"), ARDY_OK);
  ardy_planner_free(planner);
  ardy_planner_free(NULL);
}

static void test_planner_outlives_model(void) {
  ardy_model* model = NULL;
  CHECK_STATUS(ardy_model_load_from_folder(TINY, NULL, &model), ARDY_OK);
  ardy_planner* planner = NULL;
  CHECK_STATUS(ardy_planner_create(model, NULL, &planner), ARDY_OK);
  ardy_model_free(model); /* the planner keeps the package alive */
  CHECK_STATUS(ardy_planner_wait_idle(planner, 60.0), ARDY_OK);
  ardy_pose_info info;
  CHECK_STATUS(ardy_planner_sample_current(planner, &info, NULL, NULL, NULL, 0, 0), ARDY_OK);
  CHECK_STATUS(ardy_planner_set_prompt(planner, "a person walks"), ARDY_OK);
  ardy_planner_free(planner);
}

/* Two characters sharing a batcher: their first windows run as one batch. */
static void test_batcher(void) {
  ardy_model* model = NULL;
  CHECK_STATUS(ardy_model_load_from_folder(TINY, NULL, &model), ARDY_OK);
  ardy_batcher* batcher = NULL;
  ardy_batcher_params bp = ardy_batcher_default_params();
  CHECK(bp.max_windows == 16 && bp.gather_seconds > 0.0);
  bp.max_windows = 0;
  CHECK_STATUS(ardy_batcher_create(&bp, &batcher), ARDY_ERROR_INVALID_ARGUMENT);
  CHECK(batcher == NULL);
  CHECK_CONTAINS(ardy_last_error(), "max_windows is 0");
  bp.gather_seconds = 10.0; /* the batch starts when both windows are there */
  bp.max_windows = 2;
  CHECK_STATUS(ardy_batcher_create(&bp, &batcher), ARDY_OK);

  ardy_planner_params pp = ardy_planner_default_params();
  pp.batcher = batcher;
  ardy_planner *a = NULL, *b = NULL;
  CHECK_STATUS(ardy_planner_create(model, &pp, &a), ARDY_OK);
  CHECK_STATUS(ardy_planner_create(model, &pp, &b), ARDY_OK);
  CHECK_STATUS(ardy_planner_wait_idle(a, 60.0), ARDY_OK);
  CHECK_STATUS(ardy_planner_wait_idle(b, 60.0), ARDY_OK);
  ardy_batcher_stats stats;
  CHECK_STATUS(ardy_batcher_get_stats(batcher, &stats), ARDY_OK);
  CHECK(stats.batches == 1 && stats.windows == 2 && stats.largest_batch == 2);
  CHECK_STATUS(ardy_batcher_get_stats(batcher, NULL), ARDY_ERROR_INVALID_ARGUMENT);

  /* Freed first: the planners' next windows fail with a clear message. */
  ardy_batcher_free(batcher);
  ardy_batcher_free(NULL);
  CHECK_STATUS(ardy_planner_set_prompt(a, "a person walks"), ARDY_OK);
  CHECK_STATUS(ardy_planner_wait_idle(a, 60.0), ARDY_OK);
  char message[512];
  CHECK(ardy_planner_pop_error(a, message, sizeof message));
  CHECK_CONTAINS(message, "the window batcher is gone");
  ardy_planner_free(a);
  ardy_planner_free(b);
  ardy_model_free(model);
}

int main(void) {
  test_library();
  test_load_errors();
  ardy_model* model = load_from_memory();
  CHECK(model != NULL);
  if (model) {
    test_model_queries(model);
    test_planner(model);
    ardy_model_free(model);
  }
  test_planner_outlives_model();
  test_batcher();
  {
    /* fast_threads needs the process's first ONNX Runtime environment; one
     * without a shared pool is alive here (the model above). */
    ardy_model* model_alive = NULL;
    CHECK_STATUS(ardy_model_load_from_folder(TINY, NULL, &model_alive), ARDY_OK);
    ardy_model_params fast = ardy_model_default_params();
    CHECK(!fast.fast_threads);
    fast.fast_threads = true;
    ardy_model* refused = NULL;
    CHECK(ardy_model_load_from_folder(TINY, &fast, &refused) != ARDY_OK);
    CHECK(refused == NULL);
    CHECK_CONTAINS(ardy_last_error(), "cannot use a shared thread pool");
    ardy_model_free(model_alive);
  }
  printf("test_c_api: %d checks, %d failed\n", g_checks, g_failures);
  return g_failures == 0 ? 0 : 1;
}
