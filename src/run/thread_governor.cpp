#include "stickslip/run/thread_governor.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace stickslip {

void ThreadGovernor::judge(double wall, std::optional<double> waited) {
  const double elapsed = wall - window_->wall;
  if (current_ < threads_) {
    if (wall >= lowered_until_) {  // try them again
      lowered_seconds_ += wall - lowered_since_;
      current_ = threads_;
    }
  } else if (waited && window_->waited) {
    if (*waited - *window_->waited > kMaxWait * current_ * elapsed) {
      current_ = 1;
      lowered_since_ = wall;
      lowered_until_ = wall + backoff_;
      backoff_ = std::min(2.0 * backoff_, kMaxBackoff);
    } else {
      backoff_ = kFirstBackoff;  // they got their cores: a later wait starts afresh
    }
  }
  window_ = Window{wall, waited};
}

// /proc/self/task/<tid>/schedstat: "<on cpu> <waiting on a run queue> <slices>",
// in ns. Threads that ended are no longer listed: their waits drop out, which
// only makes a window's wait look shorter.
std::optional<double> process_wait_seconds() {
  std::error_code error;
  std::filesystem::directory_iterator tasks("/proc/self/task", error);
  if (error) return std::nullopt;
  double waited = 0.0;
  for (const auto& task : tasks) {
    std::ifstream in(task.path() / "schedstat");
    double on_cpu = 0.0, waiting = 0.0;
    if (!(in >> on_cpu >> waiting)) return std::nullopt;
    waited += 1e-9 * waiting;
  }
  return waited;
}

}  // namespace stickslip
