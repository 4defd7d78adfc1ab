#pragma once
// The largest speed of each watched contact between two returns of
// Integrator::advance, from the samples of its solution the integrator
// takes anyway: the stick/slip root functions' evaluations (every accepted
// step's end and the points where a crossing is located) and, in multirate, a
// fast contact's sub-step ends. That is what slips.csv's peak speed is made of
// (output/recorders.cpp), at no cost but a comparison per sample.
//
// Samples do not come in time order: a step that crosses a root is sampled at
// its end before the integrator returns at the root inside it. A sample is
// therefore held until it is known to precede the next return: every return
// lies in the last accepted step, so whatever was sampled before that step
// began (settle) precedes it; at a return (close) the held samples up to it
// join, and those after it wait for the next.

#include <cstddef>
#include <limits>
#include <span>
#include <vector>

namespace stickslip {

class SpeedPeaks {
 public:
  explicit SpeedPeaks(std::size_t watched = 0) : open_(watched, kNone), closed_(watched, kNone) {}

  // Contact k (its index among the watched) had speed `speed` [m/s] at time t.
  void sample(std::size_t k, double t, double speed) {
    if (t < last_close_) return;  // before the last return: that interval is closed
    if (t <= settled_)
      fold(k, speed);
    else
      held_.push_back({t, k, speed});
  }
  // Every later return lies at or after t (a new step began there).
  void settle(double t) {
    settled_ = t;
    release(t);
  }
  // Sampling by the stick/slip root functions: a time beyond every earlier
  // sample is a new step's end (or an output time inside it), so all that
  // was sampled before it precedes every later return (SUNDIALS locates roots
  // and outputs in the last step taken, searching from the last return on).
  void sample_frontier(std::size_t k, double t, double speed) {
    if (t > frontier_) {
      if (frontier_ > settled_) settle(frontier_);
      frontier_ = t;
    }
    sample(k, t, speed);
  }
  // advance() returns at t: peaks() becomes the largest speed sampled in
  // [previous return, t].
  void close(double t) {
    release(t);
    closed_.swap(open_);
    std::fill(open_.begin(), open_.end(), kNone);
    last_close_ = t;
  }
  // Per watched contact, as of the last close; −∞ where nothing was sampled.
  std::span<const double> peaks() const { return closed_; }

 private:
  static constexpr double kNone = -std::numeric_limits<double>::infinity();
  struct Held {
    double t;
    std::size_t k;
    double speed;
  };
  void fold(std::size_t k, double speed) {
    if (speed > open_[k]) open_[k] = speed;
  }
  void release(double t) {
    std::size_t kept = 0;
    for (const Held& h : held_) {
      if (h.t <= t)
        fold(h.k, h.speed);
      else
        held_[kept++] = h;
    }
    held_.resize(kept);
  }

  std::vector<double> open_, closed_;
  std::vector<Held> held_;
  double settled_ = kNone, frontier_ = kNone, last_close_ = kNone;
};

}  // namespace stickslip
