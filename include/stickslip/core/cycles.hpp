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

// What F_f does in the averaging window, and so what its mean is. Only the
// first two make μ a friction coefficient: from rest the block first loads
// elastically, F_f rising as a ramp with no slip, and a window on that ramp
// gives a μ that falls as 1/θ (more contacts, the same loading rate, a
// smaller F_f/F_N) — the paper's trend, produced by the wrong physics.
enum class Regime {
  steady_sliding,  // F_f constant: relative spread ≤ kSteadySpread
  stick_slip,      // else whole cycles: two or more downward crossings of the window mean
  loading,         // no whole cycle, F_f rising, the rise most of its variance
  unsettled,       // no whole cycle, neither steady nor a ramp (a cycle cut short)
};
const char* to_string(Regime r);

// Below it F_f counts as constant. Steady sliding on 6×6×4 (cases/steady.toml)
// has 4e-10; stick-slip windows have 0.09–0.3, loading ramps ~0.2.
inline constexpr double kSteadySpread = 1e-3;
// A ramp: the straight line through F_f explains this share of its variance
// or more. Loading windows from rest measured ≥ 0.99998; stick-slip windows
// ≤ 0.03 (whole cycles or not, the sawtooth's swings are not a line).
inline constexpr double kRampShare = 0.75;

struct WindowRegime {
  Regime kind = Regime::unsettled;
  double drift = 0.0;        // the fitted line's change across the window over mean F
  double trend_share = 0.0;  // of F's variance explained by that line, in [0, 1]
  // μ is a time-averaged friction coefficient only in these two.
  bool mu_trusted() const { return kind == Regime::stick_slip || kind == Regime::steady_sliding; }
};

// The regime of F (samples with t ≥ t_from, as whole_cycle_mean) given its
// whole-cycle mean and relative spread from the same samples.
WindowRegime classify_window(std::span<const double> t, std::span<const double> f, double t_from,
                             const CycleMean& cycles, double spread);

}  // namespace stickslip
