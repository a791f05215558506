#include "pointfair/tiles/pipeline.hpp"

#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

#include "pointfair/common/params_error.hpp"

namespace pointfair::tiles {

namespace {

// The state shared by the calling thread (reads, writes) and the worker (computes).
struct Shared {
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t read = 0;      // items read (the worker may compute items below it)
  std::size_t computed = 0;  // items computed (the caller may write items below it)
  bool stop = false;         // the caller gave up: the worker ends
  std::exception_ptr error;  // the worker's exception
};

void compute_items(std::size_t count, std::size_t slots, const PipelineStages& stages, Shared& s) {
  for (std::size_t i = 0; i < count; ++i) {
    {
      std::unique_lock lock(s.mutex);
      s.changed.wait(lock, [&] { return s.stop || s.read > i; });
      if (s.stop) return;
    }
    try {
      stages.compute(i % slots);
    } catch (...) {
      const std::lock_guard lock(s.mutex);
      s.error = std::current_exception();
      s.changed.notify_all();
      return;
    }
    const std::lock_guard lock(s.mutex);
    s.computed = i + 1;
    s.changed.notify_all();
  }
}

// Stops and joins the worker however the caller's loop ends.
struct JoinWorker {
  Shared& s;
  std::thread& worker;
  ~JoinWorker() {
    {
      const std::lock_guard lock(s.mutex);
      s.stop = true;
    }
    s.changed.notify_all();
    if (worker.joinable()) worker.join();
  }
};

}  // namespace

void run_pipeline(std::size_t count, std::size_t slots, const PipelineStages& stages) {
  require(slots >= 1, "a pipeline needs at least one slot");
  if (slots == 1 || count <= 1) {
    for (std::size_t i = 0; i < count; ++i) {
      stages.read(i, 0);
      stages.compute(0);
      stages.write(i, 0);
    }
    return;
  }
  Shared s;
  std::thread worker([&] { compute_items(count, slots, stages, s); });
  const JoinWorker join{s, worker};
  std::size_t read = 0, written = 0;
  while (written < count) {
    bool can_write = false;
    {
      std::unique_lock lock(s.mutex);
      // Write what is computed first (it frees a slot); else read ahead into a free slot;
      // else wait for the worker.
      s.changed.wait(lock, [&] {
        return s.error || s.computed > written || (read < count && read - written < slots);
      });
      if (s.error) std::rethrow_exception(s.error);
      can_write = s.computed > written;
    }
    if (can_write) {
      stages.write(written, written % slots);
      ++written;
      continue;
    }
    stages.read(read, read % slots);
    ++read;
    const std::lock_guard lock(s.mutex);
    s.read = read;
    s.changed.notify_all();
  }
}

}  // namespace pointfair::tiles
