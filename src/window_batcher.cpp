#include "window_batcher.hpp"

#include "generation_cpu.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace ardy {
namespace {

using SteadyClock = std::chrono::steady_clock;

// How often a waiting planner worker asks its own cancel check.
constexpr std::chrono::milliseconds kCancelPoll{1};

struct Request {
  std::shared_ptr<const ModelPackage> package;  // kept alive while its batch runs
  WindowInput input;
  std::vector<float> noise;
  SteadyClock::time_point arrived;
  bool withdrawn = false;  // the planner stopped waiting
  bool done = false;
  std::optional<WindowResult> result;
  std::exception_ptr error;
};

}  // namespace

struct WindowBatcher::State {
  WindowBatcherConfig config;
  std::mutex mutex;  // everything below
  std::condition_variable work;      // the batcher thread waits on it
  std::condition_variable finished;  // planner workers wait on it
  std::deque<std::shared_ptr<Request>> queue;
  bool stop = false;
  WindowBatcherStats stats;

  void run();
  std::vector<std::shared_ptr<Request>> take_batch();
  WindowResult submit(const std::shared_ptr<const ModelPackage>& package, const WindowInput& input,
                      const std::vector<float>& noise, const CancelCheck& cancel);
};

// Under the mutex: the first queued window and the queued ones with its
// package and step count, oldest first, up to max_windows.
std::vector<std::shared_ptr<Request>> WindowBatcher::State::take_batch() {
  std::vector<std::shared_ptr<Request>> batch;
  const ModelPackage* package = queue.front()->package.get();
  const size_t steps = queue.front()->input.steps;
  for (auto it = queue.begin(); it != queue.end() && batch.size() < config.max_windows;) {
    if ((*it)->package.get() == package && (*it)->input.steps == steps) {
      batch.push_back(*it);
      it = queue.erase(it);
    } else {
      ++it;
    }
  }
  return batch;
}

void WindowBatcher::State::run() {
  const GenerationThreadScope counted;
  const auto gather = std::chrono::duration_cast<SteadyClock::duration>(
      std::chrono::duration<double>(config.gather_seconds));
  std::unique_lock<std::mutex> lock(mutex);
  for (;;) {
    work.wait(lock, [&] { return stop || !queue.empty(); });
    if (stop) break;
    const SteadyClock::time_point gather_end = queue.front()->arrived + gather;
    work.wait_until(lock, gather_end, [&] { return stop || queue.size() >= config.max_windows; });
    if (stop) break;
    if (queue.empty()) continue;  // every waiting window was withdrawn
    const std::vector<std::shared_ptr<Request>> batch = take_batch();
    lock.unlock();

    std::vector<const WindowInput*> inputs;
    std::vector<const std::vector<float>*> noises;
    for (const auto& r : batch) {
      inputs.push_back(&r->input);
      noises.push_back(&r->noise);
    }
    const CancelCheck cancel_batch = [&] {
      std::lock_guard<std::mutex> guard(mutex);
      return stop || std::all_of(batch.begin(), batch.end(), [](const auto& r) { return r->withdrawn; });
    };
    std::vector<WindowResult> results;
    std::exception_ptr error;
    bool failed = false;
    try {
      results = generate_windows(*batch.front()->package, inputs, noises, cancel_batch);
    } catch (const Cancelled&) {
      error = std::current_exception();
    } catch (...) {
      error = std::current_exception();
      failed = true;
    }

    lock.lock();
    stats.failed_batches += failed ? 1 : 0;
    ++stats.batches;
    stats.windows += batch.size();
    stats.largest_batch = std::max(stats.largest_batch, batch.size());
    for (size_t i = 0; i < batch.size(); ++i) {
      Request& r = *batch[i];
      if (error) {
        r.error = error;
      } else {
        r.result = std::move(results[i]);
      }
      r.done = true;
    }
    finished.notify_all();
  }
  for (const auto& r : queue) {
    r->error = std::make_exception_ptr(Error("window batcher: stopped before the window ran"));
    r->done = true;
  }
  queue.clear();
  finished.notify_all();
}

WindowResult WindowBatcher::State::submit(const std::shared_ptr<const ModelPackage>& package, const WindowInput& input,
                                          const std::vector<float>& noise, const CancelCheck& cancel) {
  if (!package) throw Error("window batcher: no model package given");
  auto request = std::make_shared<Request>();
  request->package = package;
  request->input = input;
  request->noise = noise;
  request->arrived = SteadyClock::now();
  std::unique_lock<std::mutex> lock(mutex);
  if (stop) throw Error("window batcher: the window batcher is gone (give the planner a generator of a live one)");
  queue.push_back(request);
  work.notify_one();
  while (!request->done) {
    if (finished.wait_for(lock, kCancelPoll, [&] { return request->done; })) break;
    // The planner's check runs without the batcher's lock (it takes its own).
    lock.unlock();
    const bool cancelled = cancel && cancel();
    lock.lock();
    if (cancelled && !request->done) {
      request->withdrawn = true;
      queue.erase(std::remove(queue.begin(), queue.end(), request), queue.end());
      ++stats.withdrawn;
      work.notify_one();
      throw Cancelled();
    }
  }
  if (request->error) std::rethrow_exception(request->error);
  return std::move(*request->result);
}

WindowBatcher::WindowBatcher(WindowBatcherConfig config) : config_(config) {
  if (!std::isfinite(config_.gather_seconds) || config_.gather_seconds < 0.0 || config_.gather_seconds > 10.0) {
    throw Error("WindowBatcher config: gather_seconds is " + std::to_string(config_.gather_seconds) +
                ", expected 0..10 seconds");
  }
  if (config_.max_windows == 0 || config_.max_windows > 1024) {
    throw Error("WindowBatcher config: max_windows is " + std::to_string(config_.max_windows) + ", expected 1..1024");
  }
  state_ = std::make_shared<State>();
  state_->config = config_;
  thread_ = std::thread([state = state_] { state->run(); });
}

WindowBatcher::~WindowBatcher() {
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->stop = true;
  }
  state_->work.notify_all();
  thread_.join();
}

WindowGenerator WindowBatcher::generator() const {
  return [state = state_](const std::shared_ptr<const ModelPackage>& package, const WindowInput& input,
                          const std::vector<float>& noise, const CancelCheck& cancel) {
    return state->submit(package, input, noise, cancel);
  };
}

WindowBatcherStats WindowBatcher::stats() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  WindowBatcherStats s = state_->stats;
  s.queued = state_->queue.size();
  return s;
}

}  // namespace ardy
