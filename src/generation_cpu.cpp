#include "generation_cpu.hpp"

#include <mutex>
#include <vector>

#ifdef _WIN32
#include <windows.h>
#else
#include <pthread.h>
#include <time.h>
#endif

namespace ardy {
namespace {

// A handle that can read another live thread's CPU clock.
#ifdef _WIN32
using ThreadClock = HANDLE;

ThreadClock current_thread_clock() {
  HANDLE handle = nullptr;
  DuplicateHandle(GetCurrentProcess(), GetCurrentThread(), GetCurrentProcess(), &handle, THREAD_QUERY_INFORMATION,
                  FALSE, 0);
  return handle;
}

double clock_seconds(ThreadClock clock) {
  FILETIME created, exited, kernel, user;
  if (clock == nullptr || !GetThreadTimes(clock, &created, &exited, &kernel, &user)) return 0.0;
  const auto ticks = [](const FILETIME& time) {
    return (static_cast<unsigned long long>(time.dwHighDateTime) << 32) | time.dwLowDateTime;
  };
  return static_cast<double>(ticks(kernel) + ticks(user)) * 1e-7;  // 100 ns units
}

void release_clock(ThreadClock clock) {
  if (clock != nullptr) CloseHandle(clock);
}
#else
using ThreadClock = clockid_t;

ThreadClock current_thread_clock() {
  clockid_t clock = CLOCK_THREAD_CPUTIME_ID;
  pthread_getcpuclockid(pthread_self(), &clock);
  return clock;
}

double clock_seconds(ThreadClock clock) {
  timespec now{};
  if (clock_gettime(clock, &now) != 0) return 0.0;
  return static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) * 1e-9;
}

void release_clock(ThreadClock) {}
#endif

struct Registry {
  std::mutex mutex;
  double finished_seconds = 0.0;  // used by threads that have ended
  std::vector<ThreadClock> clocks;
  std::vector<bool> live;
  std::vector<int> free_slots;
};

// Never destroyed: threads of static objects may end after main returns.
Registry& registry() {
  static Registry* instance = new Registry();  // NOLINT: intentionally leaked
  return *instance;
}

}  // namespace

GenerationThreadScope::GenerationThreadScope() {
  Registry& shared = registry();
  const ThreadClock clock = current_thread_clock();
  std::lock_guard<std::mutex> lock(shared.mutex);
  if (!shared.free_slots.empty()) {
    slot_ = shared.free_slots.back();
    shared.free_slots.pop_back();
    shared.clocks[static_cast<size_t>(slot_)] = clock;
    shared.live[static_cast<size_t>(slot_)] = true;
  } else {
    slot_ = static_cast<int>(shared.clocks.size());
    shared.clocks.push_back(clock);
    shared.live.push_back(true);
  }
}

GenerationThreadScope::~GenerationThreadScope() {
  Registry& shared = registry();
  // Read while the thread still runs: an ended thread's clock is gone.
  const double used = thread_cpu_seconds();
  std::lock_guard<std::mutex> lock(shared.mutex);
  const size_t slot = static_cast<size_t>(slot_);
  shared.finished_seconds += used;
  release_clock(shared.clocks[slot]);
  shared.live[slot] = false;
  shared.free_slots.push_back(slot_);
}

double generation_cpu_seconds() {
  Registry& shared = registry();
  std::lock_guard<std::mutex> lock(shared.mutex);
  double total = shared.finished_seconds;
  for (size_t slot = 0; slot < shared.clocks.size(); ++slot) {
    if (shared.live[slot]) total += clock_seconds(shared.clocks[slot]);
  }
  return total;
}

double thread_cpu_seconds() {
#ifdef _WIN32
  return clock_seconds(GetCurrentThread());
#else
  return clock_seconds(CLOCK_THREAD_CPUTIME_ID);
#endif
}

}  // namespace ardy
