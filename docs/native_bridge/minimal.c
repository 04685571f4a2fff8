/* The native bridge from C: load a model package, stream three seconds of
 * motion for a prompt at 30 frames per second (as a game loop would), and
 * print where the character's hands and hips are every half second.
 *
 *   cc -I include minimal.c -L lib -lardy_c -Wl,-rpath,'$ORIGIN/../lib' -o bin/minimal
 *   bin/minimal models/default "a person walks forward and waves"
 */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "ardy_c.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: %s MODEL_FOLDER PROMPT\n", argv[0]);
    return 2;
  }
  ardy_model* model = NULL;
  if (ardy_model_load_from_folder(argv[1], NULL, &model) != ARDY_OK) {
    fprintf(stderr, "cannot load the model: %s\n", ardy_last_error());
    return 1;
  }
  ardy_planner* planner = NULL;
  if (ardy_planner_create(model, NULL, &planner) != ARDY_OK) {
    fprintf(stderr, "cannot create a planner: %s\n", ardy_last_error());
    ardy_model_free(model);
    return 1;
  }
  if (ardy_planner_set_prompt(planner, argv[2]) != ARDY_OK) {
    fprintf(stderr, "prompt refused: %s\n", ardy_planner_last_error(planner));
  }

  const size_t joints = ardy_model_joint_count(model);
  const int32_t hips = ardy_model_joint_index(model, "Hips");
  const int32_t hand_left = ardy_model_joint_index(model, "Hand_L");
  const int32_t hand_right = ardy_model_joint_index(model, "Hand_R");
  float* positions = malloc(joints * 3 * sizeof(float));
  printf("ARDY %s (ONNX Runtime %s), %zu joints at %.0f fps\n", ardy_version(), ardy_onnxruntime_version(), joints,
         ardy_model_fps(model));

  /* A game would not wait; here the first window is made before playing. */
  ardy_planner_wait_idle(planner, 60.0);
  const double dt = 1.0 / 30.0;
  int status = 0;
  const struct timespec frame_time = {0, 33333333};
  for (int frame = 0; frame <= 90; ++frame) {
    if (frame > 0) {
      nanosleep(&frame_time, NULL); /* the game's frame; the planner generates meanwhile */
      ardy_planner_advance(planner, dt);
    }
    ardy_pose_info info;
    if (ardy_planner_sample_current(planner, &info, NULL, positions, NULL, joints, 0) != ARDY_OK) {
      fprintf(stderr, "sample failed: %s\n", ardy_planner_last_error(planner));
      status = 1;
      break;
    }
    if (frame % 15 == 0) {
      const float* h = positions + 3 * hips;
      const float* l = positions + 3 * hand_left;
      const float* r = positions + 3 * hand_right;
      printf("t %.2f s  hips %.2f %.2f %.2f  left hand %.2f %.2f %.2f  right hand %.2f %.2f %.2f\n", info.time,
             h[0], h[1], h[2], l[0], l[1], l[2], r[0], r[1], r[2]);
    }
  }
  char error[512];
  while (ardy_planner_pop_error(planner, error, sizeof error)) fprintf(stderr, "worker: %s\n", error);

  free(positions);
  ardy_planner_free(planner);
  ardy_model_free(model);
  return status;
}
