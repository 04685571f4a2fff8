#pragma once

// CPU time spent generating motion, process-wide: "how many cores does
// generation use" as a measured figure for HUDs and benches. The threads that
// generate (planner workers, the window batcher, ONNX Runtime's shared
// intra-op pool) register themselves for as long as they run; the total is
// what the live ones have used so far plus what the finished ones used.

namespace ardy {

// Registers the calling thread for its lifetime (make one at the top of a
// generation thread's body). Not copyable, not movable.
class GenerationThreadScope {
 public:
  GenerationThreadScope();
  ~GenerationThreadScope();
  GenerationThreadScope(const GenerationThreadScope&) = delete;
  GenerationThreadScope& operator=(const GenerationThreadScope&) = delete;

 private:
  int slot_ = -1;
};

// CPU seconds (user + system) used by generation threads since the process
// started, over every thread registered so far. Monotonic; callable from any
// thread.
double generation_cpu_seconds();

// The CPU seconds the calling thread has used.
double thread_cpu_seconds();

}  // namespace ardy
