#include "pointfair/common/parallel.hpp"

#include "pointfair/common/params_error.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#if defined(POINTFAIR_USE_TBB)
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#elif defined(POINTFAIR_USE_OPENMP)
#include <omp.h>
#endif

namespace pointfair {
namespace {

int default_threads() {
#if defined(POINTFAIR_USE_TBB)
  return tbb::info::default_concurrency();
#elif defined(POINTFAIR_USE_OPENMP)
  return omp_get_num_procs();
#else  // std::thread back end
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
#endif
}

struct ThreadSetting {
  std::mutex mutex;
  int threads = 0;  // 0: default
#if defined(POINTFAIR_USE_TBB)
  std::unique_ptr<tbb::global_control> control;
#endif
};

ThreadSetting& setting() {
  static ThreadSetting s;
  return s;
}

std::atomic<const std::atomic<int>*> g_stop_flag{nullptr};

}  // namespace

void set_stop_flag(const std::atomic<int>* flag) { g_stop_flag.store(flag); }

void set_thread_count(int threads) {
  require(threads >= 0, "thread count must be >= 0, got " + std::to_string(threads));
  auto& s = setting();
  std::lock_guard lock(s.mutex);
  s.threads = threads;
#if defined(POINTFAIR_USE_TBB)
  s.control.reset();
  if (threads > 0)
    s.control = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
#endif
}

int thread_count() {
  auto& s = setting();
  std::lock_guard lock(s.mutex);
  return s.threads > 0 ? s.threads : default_threads();
}

namespace {

void run_parallel(std::size_t n, const std::function<void(std::size_t, std::size_t)>& body, std::size_t grain);

}  // namespace

void parallel_for(std::size_t n, const std::function<void(std::size_t, std::size_t)>& body,
                  std::size_t grain) {
  if (n == 0) return;
  grain = std::max<std::size_t>(grain, 1);
  const std::atomic<int>* stop = g_stop_flag.load();
  if (stop == nullptr) {
    run_parallel(n, body, grain);
    return;
  }
  // Each range checks the flag first; the results do not depend on how [0, n) is cut.
  if (stop->load(std::memory_order_relaxed) != 0) throw Stopped();
  std::atomic<bool> skipped{false};
  const auto checked = [&](std::size_t begin, std::size_t end) {
    for (std::size_t first = begin; first < end; first += kStopCheckRange) {
      if (stop->load(std::memory_order_relaxed) != 0) {
        skipped.store(true, std::memory_order_relaxed);
        return;
      }
      body(first, std::min(end, first + kStopCheckRange));
    }
  };
  run_parallel(n, checked, grain);
  if (skipped.load()) throw Stopped();
}

namespace {

void run_parallel(std::size_t n, const std::function<void(std::size_t, std::size_t)>& body, std::size_t grain) {
  const int threads = thread_count();
  if (threads == 1 || n <= grain) {
    body(0, n);
    return;
  }
#if defined(POINTFAIR_USE_TBB)
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
#elif defined(POINTFAIR_USE_OPENMP)
  const std::size_t chunks = (n + grain - 1) / grain;
  // Exceptions must not escape an OpenMP region: keep the first and rethrow after it.
  std::exception_ptr error;
  std::mutex error_mutex;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t c = 0; c < chunks; ++c) {
    try {
      body(c * grain, std::min(n, (c + 1) * grain));
    } catch (...) {
      std::lock_guard lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
#else
  // Plain std::thread back end (POINTFAIR_PARALLEL=Threads): threads started per call, taking
  // grain-sized chunks from a shared counter. Slower to start than a pool, but every
  // synchronisation is a thread start, an atomic or a join, which ThreadSanitizer sees.
  const std::size_t chunks = (n + grain - 1) / grain;
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto work = [&] {
    for (std::size_t c = next.fetch_add(1); c < chunks; c = next.fetch_add(1)) {
      try {
        body(c * grain, std::min(n, (c + 1) * grain));
      } catch (...) {
        std::lock_guard lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  const std::size_t helpers = std::min<std::size_t>(static_cast<std::size_t>(threads), chunks) - 1;
  std::vector<std::thread> pool;
  pool.reserve(helpers);
  for (std::size_t t = 0; t < helpers; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
#endif
}

}  // namespace

}  // namespace pointfair
