/* Prints the size of every struct of src/ardy_c.h and the offset of every
 * field, one "name value" a line; Tests.cs checks the C# declarations of
 * bindings/csharp/Ardy/NativeMethods.cs against it (run_tests.sh builds it). */
#include <stddef.h>
#include <stdio.h>

#include "ardy_c.h"

#define SIZE(T) printf("%s %zu\n", #T, sizeof(T))
#define FIELD(T, f) printf("%s.%s %zu\n", #T, #f, offsetof(T, f))

int main(void) {
  SIZE(ardy_model_params);
  FIELD(ardy_model_params, intra_op_threads);
  FIELD(ardy_model_params, text_cache_capacity);
  FIELD(ardy_model_params, max_prompt_chars);
  FIELD(ardy_model_params, fast_threads);
  SIZE(ardy_file_buffer);
  FIELD(ardy_file_buffer, name);
  FIELD(ardy_file_buffer, data);
  FIELD(ardy_file_buffer, size);
  SIZE(ardy_planner_params);
  FIELD(ardy_planner_params, steps);
  FIELD(ardy_planner_params, w_text);
  FIELD(ardy_planner_params, w_con);
  FIELD(ardy_planner_params, path_guidance_scale);
  FIELD(ardy_planner_params, text_only_guidance_scale);
  FIELD(ardy_planner_params, history_seconds);
  FIELD(ardy_planner_params, future_seconds);
  FIELD(ardy_planner_params, start_x);
  FIELD(ardy_planner_params, start_z);
  FIELD(ardy_planner_params, seed);
  FIELD(ardy_planner_params, min_buffer_frames);
  FIELD(ardy_planner_params, initial_latency_seconds);
  FIELD(ardy_planner_params, latency_margin);
  FIELD(ardy_planner_params, low_water_seconds);
  FIELD(ardy_planner_params, keep_behind_seconds);
  FIELD(ardy_planner_params, cancel_obsolete_windows);
  FIELD(ardy_planner_params, output_smoothing_frames);
  FIELD(ardy_planner_params, interpolate_root);
  FIELD(ardy_planner_params, max_root_speed);
  FIELD(ardy_planner_params, foot_lock);
  FIELD(ardy_planner_params, batcher);
  FIELD(ardy_planner_params, initial_history);
  FIELD(ardy_planner_params, initial_history_frames);
  SIZE(ardy_batcher_params);
  FIELD(ardy_batcher_params, gather_seconds);
  FIELD(ardy_batcher_params, max_windows);
  SIZE(ardy_batcher_stats);
  FIELD(ardy_batcher_stats, batches);
  FIELD(ardy_batcher_stats, windows);
  FIELD(ardy_batcher_stats, withdrawn);
  FIELD(ardy_batcher_stats, failed_batches);
  FIELD(ardy_batcher_stats, largest_batch);
  FIELD(ardy_batcher_stats, queued);
  SIZE(ardy_pose_info);
  FIELD(ardy_pose_info, time);
  FIELD(ardy_pose_info, root_position);
  FIELD(ardy_pose_info, heading);
  FIELD(ardy_pose_info, window_id);
  SIZE(ardy_planner_stats);
  FIELD(ardy_planner_stats, windows_started);
  FIELD(ardy_planner_stats, windows_published);
  FIELD(ardy_planner_stats, splices);
  FIELD(ardy_planner_stats, late_windows);
  FIELD(ardy_planner_stats, cancelled_windows);
  FIELD(ardy_planner_stats, failed_windows);
  FIELD(ardy_planner_stats, commands);
  FIELD(ardy_planner_stats, errors);
  FIELD(ardy_planner_stats, last_latency_seconds);
  FIELD(ardy_planner_stats, latency_estimate_seconds);
  FIELD(ardy_planner_stats, buffer_frames);
  FIELD(ardy_planner_stats, underrun_seconds);
  FIELD(ardy_planner_stats, playhead);
  FIELD(ardy_planner_stats, queued_seconds);
  FIELD(ardy_planner_stats, window_in_flight);
  printf("sizeof_ardy_status %zu\n", sizeof(ardy_status));
  return 0;
}
