#pragma once
// The one parallel facade of the library. Kernels call parallel_for; the back end (TBB,
// OpenMP or plain std::thread, chosen at configure time) is hidden in parallel.cpp.
//
// Thread-safety: `body` is called concurrently for disjoint index ranges; it must not write
// shared state except through the range it is given. Results therefore do not depend on the
// number of threads, as long as each index's work depends only on its own inputs.
#include <cstddef>
#include <functional>

namespace pointfair {

/// Number of worker threads used by parallel_for; 0 restores the default (all cores).
void set_thread_count(int threads);
/// Number of worker threads parallel_for will use.
int thread_count();

/// Calls body(begin, end) over disjoint sub-ranges covering [0, n). `grain` is the smallest
/// range worth a task.
void parallel_for(std::size_t n, const std::function<void(std::size_t, std::size_t)>& body,
                  std::size_t grain = 1024);

}  // namespace pointfair
