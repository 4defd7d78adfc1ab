#pragma once
// The friction force averaged over whole cycles. Where the block stick-slips
// as a whole (high coverage), F_f is a sawtooth with a period of several ms,
// and a fixed window [t_avg, t_end] holding a fraction of a cycle more or less
// biases the mean by up to a few % (docs/RESULTS.md). Averaging between the
// first and the last time F_f falls through its window mean starts and ends
// the average at the same phase of the cycle, so only whole cycles count.
// Where F_f has no cycle (steady sliding, many small independent slips) the
// crossings are many or none and the result is the window mean, or close to it.

#include <span>

namespace stickslip {

struct CycleMean {
  double mean = 0.0;            // mean of F over [from, to]
  double from = 0.0, to = 0.0;  // the first and last downward crossings (the window if < 2)
  long crossings = 0;           // downward crossings of the window mean in the window
};

// F sampled at times t (increasing); only samples with t ≥ t_from count.
// Between samples F is linear (the trapezoidal rule; the crossings are
// interpolated). With fewer than two crossings, the mean over the whole
// window. Throws std::invalid_argument with fewer than two samples in the
// window or sizes that differ.
CycleMean whole_cycle_mean(std::span<const double> t, std::span<const double> f, double t_from);

// The standard deviation of F over its mean, of the samples with t ≥ t_from
// (equally spaced output samples): how far F_f swings about μ F_N, the size of
// block-scale stick-slip (MODEL.md §14). Throws std::invalid_argument with
// fewer than two samples in the window or sizes that differ.
double relative_spread(std::span<const double> t, std::span<const double> f, double t_from);

}  // namespace stickslip
