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

// A run's threads: the count it was given ([solver] threads, resolved by
// resolved_threads) and, of those, what its loops use now. The run owns it
// and lowers `now` while its threads do not get their cores (ThreadGovernor,
// run/thread_governor.hpp); the integrators read it through their options
// (IntegratorOptions::threads) and hand it to every parallel loop, the
// System's among them. The machine's load, not the physics: results do not
// depend on it (parallel_for), so it may change between any two steps.
class ThreadBudget {
 public:
  explicit ThreadBudget(int threads = 1) : threads_(threads < 1 ? 1 : threads), now_(threads_) {}
  int threads() const { return threads_; }
  int now() const { return now_; }
  // Clamped to [1, threads()].
  void set_now(int threads) { now_ = threads < 1 ? 1 : threads > threads_ ? threads_ : threads; }

 private:
  int threads_;
  int now_;
};

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
