#pragma once
// The one parallel facade of the library. Kernels call parallel_for; the back end (TBB,
// OpenMP or plain std::thread, chosen at configure time) is hidden in parallel.cpp.
//
// Thread-safety: `body` is called concurrently for disjoint index ranges; it must not write
// shared state except through the range it is given. Results therefore do not depend on the
// number of threads, as long as each index's work depends only on its own inputs.
#include <atomic>
#include <cstddef>
#include <functional>
#include <stdexcept>

namespace pointfair {

/// Thrown by parallel_for once the stop flag (set_stop_flag) is set: the ranges not yet
/// started were skipped, so what the loop writes is incomplete.
class Stopped : public std::runtime_error {
 public:
  Stopped() : std::runtime_error("stopped") {}
};

/// A flag that, once non-zero, makes every parallel_for skip the ranges it has not started
/// and throw Stopped: a long run ends within one range's work (a signal handler may set it;
/// the flag must outlive its use). Null: none. Ranges are then at most kStopCheckRange
/// indices long even on one thread.
void set_stop_flag(const std::atomic<int>* flag);
inline constexpr std::size_t kStopCheckRange = std::size_t{1} << 14;

/// Number of worker threads used by parallel_for; 0 restores the default (all cores).
void set_thread_count(int threads);
/// Number of worker threads parallel_for will use.
int thread_count();

/// Calls body(begin, end) over disjoint sub-ranges covering [0, n). `grain` is the smallest
/// range worth a task.
void parallel_for(std::size_t n, const std::function<void(std::size_t, std::size_t)>& body,
                  std::size_t grain = 1024);

}  // namespace pointfair
