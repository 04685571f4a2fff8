#pragma once

// Several characters' windows in one denoiser call per step (design.md
// section 3: the batch axis exists in every graph). Planners that share a
// WindowBatcher (PlannerConfig::generator = batcher.generator()) hand their
// windows to its one inference thread. It gathers the windows that arrive
// within gather_seconds of the first (the planners of a scene tend to replan
// in the same frame: a prompt for everyone, the queues running low together)
// and runs those of the same package and step count as one batch
// (generate_windows): one denoiser call per step for all of them, one decoder
// call per window. On a CPU this costs far less per window than running them
// one after the other (bench/ prints the ratio).
//
// A planner's worker waits for its window. When its own cancel check fires
// (the planner is being destroyed, or the window became obsolete) it stops
// waiting at once and gets Cancelled; the batch goes on for the others and
// drops that window's result. The batcher copies every input it is given,
// so nothing it runs belongs to a planner. A batch failing (a graph error)
// fails each of its windows with that error.
//
// Destroying the WindowBatcher fails its queued windows, waits for the batch
// in flight, and stops the thread; generators still held by planners then
// fail every window with a clear error ("the window batcher is gone").

#include <cstddef>
#include <cstdint>
#include <memory>
#include <thread>

#include "sampler.hpp"

namespace ardy {

struct WindowBatcherConfig {
  double gather_seconds = 0.002;  // after the first window of a batch, wait this long for more
  size_t max_windows = 16;        // windows per batch (a full batch starts at once)
};

struct WindowBatcherStats {
  uint64_t batches = 0;
  uint64_t windows = 0;         // windows run in a batch
  uint64_t withdrawn = 0;       // windows whose planner stopped waiting (cancelled)
  uint64_t failed_batches = 0;
  size_t largest_batch = 0;
  size_t queued = 0;            // windows waiting for a batch now
};

class WindowBatcher {
 public:
  // Error for a negative or non-finite gather_seconds or max_windows 0.
  explicit WindowBatcher(WindowBatcherConfig config = {});
  ~WindowBatcher();
  WindowBatcher(const WindowBatcher&) = delete;
  WindowBatcher& operator=(const WindowBatcher&) = delete;

  // A window generator for PlannerConfig::generator; any number of planners
  // may hold one. Blocks the calling thread until its window is done.
  WindowGenerator generator() const;
  WindowBatcherStats stats() const;
  const WindowBatcherConfig& config() const { return config_; }

 private:
  struct State;
  WindowBatcherConfig config_;
  std::shared_ptr<State> state_;
  std::thread thread_;  // last: started when the state exists
};

}  // namespace ardy
