// The process-wide count of CPU time spent generating (generation_cpu.hpp):
// registered threads count, with what they used both while they run and after
// they end; other threads do not.

#include <catch_amalgamated.hpp>

#include <atomic>
#include <thread>

#include "generation_cpu.hpp"

namespace {

// Burns CPU on the calling thread until it has used `seconds` of it.
void burn(double seconds) {
  const double until = ardy::thread_cpu_seconds() + seconds;
  std::atomic<double> sink{0.0};
  while (ardy::thread_cpu_seconds() < until) sink = sink + 1.0;
}

}  // namespace

TEST_CASE("a registered thread's CPU time counts as generation, while it runs and after it ends", "[cpu]") {
  const double before = ardy::generation_cpu_seconds();
  double used_by_thread = 0.0;
  double counted_while_running = 0.0;
  std::thread worker([&] {
    const ardy::GenerationThreadScope counted;
    const double start = ardy::thread_cpu_seconds();
    burn(0.15);
    used_by_thread = ardy::thread_cpu_seconds() - start;
    counted_while_running = ardy::generation_cpu_seconds() - before;
  });
  worker.join();
  const double counted_after = ardy::generation_cpu_seconds() - before;
  // The thread's own work, plus the little it used before measuring began.
  CHECK(used_by_thread >= 0.15);
  CHECK(counted_while_running >= used_by_thread);
  CHECK(counted_while_running <= used_by_thread + 0.02);
  CHECK(counted_after >= counted_while_running);
  CHECK(counted_after <= used_by_thread + 0.02);
}

TEST_CASE("threads that do not register are not counted, and a slot is reused", "[cpu]") {
  const double before = ardy::generation_cpu_seconds();
  std::thread other([] { burn(0.1); });
  other.join();
  burn(0.05);  // the calling thread is not registered either
  CHECK(ardy::generation_cpu_seconds() - before < 0.005);
  // Many short-lived registered threads: each is counted once.
  const double before_many = ardy::generation_cpu_seconds();
  for (int i = 0; i < 20; ++i) {
    std::thread worker([] {
      const ardy::GenerationThreadScope counted;
      burn(0.005);
    });
    worker.join();
  }
  const double counted = ardy::generation_cpu_seconds() - before_many;
  CHECK(counted >= 0.1);
  CHECK(counted < 0.1 + 20 * 0.002);
}
