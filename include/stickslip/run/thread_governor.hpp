#pragma once
// Whether a run's threads get their cores, and how many to use while they do
// not.
//
// A run on several threads ([solver] threads) joins them at the end of every
// loop, thousands of times a step. Where another job holds one of the cores,
// a thread waits for its turn there and every join waits with it: Fig. 10b on
// two threads beside one other job took 6.9 s of wall against 1.2 s on one
// thread (and 1.1 s on two, alone). The kernel counts the time each thread
// spent ready to run but waiting for a core (/proc/self/task/*/schedstat):
// ~0.9 s a second for two threads beside another job, ~0.01 alone. Window by
// window of wall time, where the run's threads waited more than kMaxWait of
// it each, the run goes on one thread, and tries its threads again after a
// backoff that doubles while they keep waiting. Results do not depend on the
// threads (parallel_for), so nothing but the wall time changes.

#include <optional>

namespace stickslip {

class ThreadGovernor {
 public:
  // Waiting for a core, per thread, as a share of a window's wall time,
  // above which the threads are taken not to get their cores.
  static constexpr double kMaxWait = 0.2;
  // Wall time a window lasts [s].
  static constexpr double kWindow = 0.5;
  // Wall time on one thread before the threads are tried again [s]; doubled
  // after each failed try, up to kMaxBackoff.
  static constexpr double kFirstBackoff = 15.0;
  static constexpr double kMaxBackoff = 240.0;

  // `threads`: the run's ([solver] threads).
  explicit ThreadGovernor(int threads) : threads_(threads < 1 ? 1 : threads), current_(threads_) {}

  // The wall clock now [s], and, read only when a window has passed (it
  // costs a few system calls), the time the process's threads have waited
  // for a core so far [s] (nullopt: not known, and nothing is changed).
  // Returns the threads to use from here on.
  template <class Waited>
  int update(double wall, Waited&& waited) {
    if (threads_ == 1) return current_;
    if (!window_) {
      window_ = Window{wall, waited()};
    } else if (wall - window_->wall >= kWindow) {
      judge(wall, waited());
    }
    return current_;
  }

  int threads() const { return current_; }
  // Wall time spent on fewer threads than the run's, up to `wall` [s].
  double lowered_seconds(double wall) const {
    return lowered_seconds_ + (current_ < threads_ ? wall - lowered_since_ : 0.0);
  }

 private:
  struct Window {
    double wall;
    std::optional<double> waited;
  };
  void judge(double wall, std::optional<double> waited);

  int threads_, current_;
  std::optional<Window> window_;  // the current window's start
  double lowered_since_ = 0.0;    // wall time the threads were last lowered
  double lowered_until_ = 0.0;    // wall time of the next try with all threads
  double backoff_ = kFirstBackoff;
  double lowered_seconds_ = 0.0;
};

// The time the calling process's threads have waited for a core so far [s],
// from the kernel's schedstat; nullopt where it does not keep them.
std::optional<double> process_wait_seconds();

}  // namespace stickslip
