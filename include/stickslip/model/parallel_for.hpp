#pragma once
// f(i) for every i in [0, n), on `threads` OpenMP threads: how a run's
// threads ([solver] threads) are used everywhere.
//
// The work is split by i alone, and each f(i) must touch only what is its
// own, so a result never depends on the number of threads: threads decide
// who computes an i, never how. With one thread (or n < 2) it is a plain
// loop: outlined for OpenMP, even with its `if` false, a loop ran 15–30 %
// slower. An exception thrown by f(i) cannot leave an OpenMP region; it is
// caught there, the loop finishes, and the one of the lowest i is rethrown,
// as a serial loop would have thrown first.

#include <cstdint>
#include <exception>
#include <mutex>

namespace stickslip {

template <class F>
void parallel_for(int threads, std::int64_t n, F&& f) {
  if (threads <= 1 || n < 2) {
    for (std::int64_t i = 0; i < n; ++i) f(i);
    return;
  }
  std::exception_ptr first;
  std::int64_t first_at = n;
  std::mutex failure;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::int64_t i = 0; i < n; ++i) {
    try {
      f(i);
    } catch (...) {
      const std::lock_guard lock(failure);
      if (i < first_at) {
        first_at = i;
        first = std::current_exception();
      }
    }
  }
  if (first) std::rethrow_exception(first);
}

}  // namespace stickslip
