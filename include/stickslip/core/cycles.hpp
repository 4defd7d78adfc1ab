#pragma once
// What the friction force does in the averaging window, and so what its mean
// is worth. From rest the block first loads elastically (F_f a ramp), then,
// at high coverage, stick-slips as a whole: F_f is a sawtooth whose falls
// (block slips) are followed by ringing of the lattice, oscillations far
// smaller than the fall. A window that holds part of the ramp gives a μ that
// is low, and lower the higher the load: the paper's trend from the wrong
// physics. A window holding a fraction of a cycle more or less is biased by
// up to a few %. So the analysis finds the block slips (falls larger than
// the ringing), averages over whole cycles between them, gives the window's
// mean a standard error, and judges the window, naming what would fix it.
// Where F_f has no block slip (steady sliding, many small independent slips)
// the window mean is the mean, its error from F_f's autocorrelation.

#include <limits>
#include <span>
#include <vector>

namespace stickslip {

// A fall of F larger than the ringing: from the sample where F peaks to
// where the fall bottoms out.
struct BlockSlip {
  double onset = 0.0;  // [s] the peak before the fall
  double end = 0.0;    // [s] the bottom of the fall
  double drop = 0.0;   // F(onset) − F(end)
};

// A block slip falls by at least this share of the trace's largest fall from
// a peak (its largest drawdown): ringing after a fall swings by ~15 % of it
// (8×8×5, θ = 0.5), block slips of one run differ by less than 2×.
inline constexpr double kBlockFallShare = 0.5;
// ... and by at least this share of the trace's mean |F|: a ramp with only
// ringing on it, or steady sliding's wiggles, has no block slip.
inline constexpr double kBlockFallFloor = 0.05;

// The block slips of F sampled at times t (increasing), over the whole trace:
// alternating peaks and troughs whose swing exceeds the threshold above
// (hysteresis), each fall one block slip. Throws std::invalid_argument when
// the sizes differ.
std::vector<BlockSlip> find_block_slips(std::span<const double> t, std::span<const double> f);

// F's mean over whole cycles: between the first and the last block slip's
// onset in the window, so the average starts and ends at the same phase.
struct CycleMean {
  double mean = 0.0;            // of F over [from, to] (the window mean if < 2 block slips)
  double from = 0.0, to = 0.0;  // the first and last onsets in the window (the window if < 2)
  long block_slips = 0;         // onsets in the window
  double period = 0.0;          // mean time between them [s]; NaN with fewer than two
  // The standard error of `mean` from the whole cycles' means (batch means,
  // each cycle a batch weighted by its length); NaN with fewer than two cycles.
  double error = 0.0;
};

// What F does in the averaging window. Only the first two make μ a friction
// coefficient.
enum class Regime {
  steady_sliding,  // F constant: relative spread ≤ kSteadySpread
  stick_slip,      // two or more block slips in the window, or stationary small slips
  loading,         // the window starts on the loading ramp from rest
  unsettled,       // fewer than two block slips in the window, F neither steady nor a ramp
  undersampled,    // too few samples in the window, or per block cycle, to judge it
  not_driven,      // drive.velocity = 0: no sliding to average
};
const char* to_string(Regime r);

// Below it F counts as constant. Steady sliding on 6×6×4 (cases/steady.toml)
// has 4e-10; stick-slip windows have 0.09–0.3, loading ramps ~0.2.
inline constexpr double kSteadySpread = 1e-3;
// Without a block slip, a ramp: the straight line through F explains this
// share of its variance or more. Loading windows from rest measured ≥
// 0.99998; stick-slip windows ≤ 0.03.
inline constexpr double kRampShare = 0.75;
// Fewer samples than these in the window, or per block cycle, cannot show
// what F does (a cycle's rise and fall need several samples each).
inline constexpr long kMinSamples = 10;
inline constexpr double kMinSamplesPerCycle = 10.0;

struct WindowRegime {
  Regime kind = Regime::unsettled;
  double drift = 0.0;        // the fitted line's change across the window over mean F
  double trend_share = 0.0;  // of F's variance explained by that line, in [0, 1]
  // Where the loading transient ends (the first block slip's onset, or where
  // F settles), when the window starts before it; NaN otherwise.
  double transient_ends = std::numeric_limits<double>::quiet_NaN();
  bool mu_trusted() const { return kind == Regime::stick_slip || kind == Regime::steady_sliding; }
};

struct FrictionWindow {
  long samples = 0;  // of F in the window
  // F's window mean (the trapezoidal rule over the samples) and its standard
  // error: batch means over the pieces between block slips where there are
  // block slips, else from F's autocorrelation (statistical inefficiency);
  // NaN where neither can be had (fewer than two pieces, or samples).
  double mean = 0.0, error = 0.0;
  const char* error_from = "";  // "block cycles", "autocorrelation", or ""
  double spread = 0.0;          // sd over mean of the samples; NaN with fewer than two
  CycleMean cycles;
  WindowRegime regime;
  std::vector<BlockSlip> block_slips;  // of the whole trace, which the window's cycles are cut from
};

// The samples with t ≥ t_from form the window; the block slips and the
// loading transient are found on the whole trace. `driven`: whether the
// drive moves (drive.velocity > 0). Throws std::invalid_argument when the
// sizes differ; any number of samples is judged (too few: undersampled).
FrictionWindow analyse_window(std::span<const double> t, std::span<const double> f, double t_from,
                              bool driven);

// Where a window should start (run.average_from = "auto"): after the loading
// transient. With two whole block cycles or more, at a block slip's onset:
// the first, or a later one where MSER (the marginal standard error rule,
// White 1997) over the cycles' means finds the first cycles biased; with one
// or two block slips, the first's onset; without any, MSER over batches of
// five samples. At most half the trace is cut. Returns t.front() for fewer
// than two samples.
double settled_from(std::span<const double> t, std::span<const double> f);

// The standard deviation of F over its mean, of the samples with t ≥ t_from.
// Throws std::invalid_argument with fewer than two samples in the window or
// sizes that differ.
double relative_spread(std::span<const double> t, std::span<const double> f, double t_from);

// The statistical inefficiency g of equally spaced samples x (samples per
// independent sample, ≥ 1) from their autocorrelation, summed to its first
// zero (Chodera 2016): every lag up to kDenseLags, then lags ever further
// apart, the trapezoidal rule between them; the variance of their mean is
// var(x) g / n.
inline constexpr std::size_t kDenseLags = 256;
double statistical_inefficiency(std::span<const double> x);

}  // namespace stickslip
