#include "stickslip/core/cycles.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace stickslip {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_sizes(std::span<const double> t, std::span<const double> f, const char* who) {
  if (t.size() != f.size())
    throw std::invalid_argument(std::string(who) + ": times and values differ in number");
}

// ∫ f dt from the first sample, f linear between samples (the trapezoidal
// rule), summed once: any ∫ over [a, b] is then a difference, found by
// bisection, so averaging over many pieces (batch means, MSER's cuts) costs
// no pass over the samples each.
class Antiderivative {
 public:
  Antiderivative(std::span<const double> t, std::span<const double> f)
      : t_(t), f_(f), sum_(t.size(), 0.0) {
    for (std::size_t i = 1; i < t.size(); ++i)
      sum_[i] = sum_[i - 1] + 0.5 * (f[i - 1] + f[i]) * (t[i] - t[i - 1]);
  }
  // ∫ f dt over [a, b], a ≤ b within the samples.
  double over(double a, double b) const { return at(b) - at(a); }

 private:
  double at(double s) const {  // ∫ f dt over [t_0, s]
    if (t_.size() < 2 || s <= t_.front()) return 0.0;
    if (s >= t_.back()) return sum_.back();
    const auto i =
        static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), s) - t_.begin()) - 1;
    const double fs = f_[i] + (f_[i + 1] - f_[i]) * (s - t_[i]) / (t_[i + 1] - t_[i]);
    return sum_[i] + 0.5 * (f_[i] + fs) * (s - t_[i]);
  }
  std::span<const double> t_, f_;
  std::vector<double> sum_;
};

// The mean of f over [b_0, b_m] and its standard error from the pieces
// [b_k, b_k+1] as batches: each piece's mean weighted by its length (the
// ratio estimator of batch means with unequal batches). NaN error with fewer
// than two pieces.
struct BatchMean {
  double mean = kNaN, error = kNaN;
};
BatchMean batch_mean(const Antiderivative& integral, const std::vector<double>& bounds) {
  BatchMean r;
  if (bounds.size() < 2) return r;
  std::vector<double> length, area;
  for (std::size_t k = 0; k + 1 < bounds.size(); ++k) {
    length.push_back(bounds[k + 1] - bounds[k]);
    area.push_back(integral.over(bounds[k], bounds[k + 1]));
  }
  double total = 0.0, total_area = 0.0;
  for (std::size_t k = 0; k < length.size(); ++k) total += length[k], total_area += area[k];
  r.mean = total_area / total;
  const auto m = static_cast<double>(length.size());
  if (length.size() < 2) return r;
  double s = 0.0;
  for (std::size_t k = 0; k < length.size(); ++k) {
    const double d = area[k] - length[k] * r.mean;  // T_k (m_k − μ)
    s += d * d;
  }
  r.error = std::sqrt(m / (m - 1) * s) / total;
  return r;
}

// Least squares line through the window's samples: drift across the window
// over the mean, and the share of the variance it explains.
void fit_line(std::span<const double> t, std::span<const double> f, WindowRegime& r) {
  double n = 0.0, t_mean = 0.0, f_mean = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    n += 1.0;
    t_mean += (t[i] - t_mean) / n;
    f_mean += (f[i] - f_mean) / n;
  }
  double stt = 0.0, stf = 0.0, sff = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    stt += (t[i] - t_mean) * (t[i] - t_mean);
    stf += (t[i] - t_mean) * (f[i] - f_mean);
    sff += (f[i] - f_mean) * (f[i] - f_mean);
  }
  const double slope = stt > 0 ? stf / stt : 0.0;
  r.drift = f_mean != 0.0 && !t.empty() ? slope * (t.back() - t.front()) / f_mean : 0.0;
  r.trend_share = stt > 0 && sff > 0 ? std::min(1.0, stf * stf / (stt * sff)) : 0.0;
}

long downward_crossings(std::span<const double> f, double level) {
  long n = 0;
  for (std::size_t i = 0; i + 1 < f.size(); ++i)
    if (f[i] >= level && f[i + 1] < level) ++n;
  return n;
}

// MSER: the d in [0, max_cut] minimising the squared marginal standard error
// `stat(d)` of what is left after cutting d leading batches.
template <class Stat>
std::size_t mser(std::size_t max_cut, Stat stat) {
  std::size_t best = 0;
  double best_stat = stat(0);
  for (std::size_t d = 1; d <= max_cut; ++d)
    if (const double s = stat(d); s < best_stat) best = d, best_stat = s;
  return best;
}

}  // namespace

std::vector<BlockSlip> find_block_slips(std::span<const double> t, std::span<const double> f) {
  check_sizes(t, f, "find_block_slips");
  std::vector<BlockSlip> slips;
  if (t.size() < 3) return slips;
  double peak = f[0], drawdown = 0.0, mean_abs = 0.0;
  for (double x : f) {
    peak = std::max(peak, x);
    drawdown = std::max(drawdown, peak - x);
    mean_abs += std::abs(x);
  }
  mean_abs /= static_cast<double>(f.size());
  const double h = std::max(kBlockFallShare * drawdown, kBlockFallFloor * mean_abs);
  if (!(h > 0) || drawdown < h) return slips;
  // Hysteresis: an extreme counts once F has turned from it by h.
  bool rising = true;
  std::size_t extreme = 0, onset = 0;
  for (std::size_t i = 1; i < f.size(); ++i) {
    if (rising) {
      if (f[i] > f[extreme]) {
        extreme = i;
      } else if (f[extreme] - f[i] >= h) {
        onset = extreme;
        rising = false;
        extreme = i;
      }
    } else if (f[i] < f[extreme]) {
      extreme = i;
    } else if (f[i] - f[extreme] >= h) {
      slips.push_back({t[onset], t[extreme], f[onset] - f[extreme]});
      rising = true;
      extreme = i;
    }
  }
  if (!rising) slips.push_back({t[onset], t[extreme], f[onset] - f[extreme]});  // still falling
  return slips;
}

double relative_spread(std::span<const double> t, std::span<const double> f, double t_from) {
  check_sizes(t, f, "relative_spread");
  double n = 0.0, mean = 0.0, m2 = 0.0;  // Welford: F_f's swings are small beside its mean
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] < t_from) continue;
    n += 1.0;
    const double d = f[i] - mean;
    mean += d / n;
    m2 += d * (f[i] - mean);
  }
  if (n < 2) throw std::invalid_argument("relative_spread: fewer than two samples in the window");
  return std::sqrt(m2 / (n - 1)) / mean;
}

double statistical_inefficiency(std::span<const double> x) {
  const std::size_t n = x.size();
  if (n < 2) return 1.0;
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  double var = 0.0;
  for (double v : x) var += (v - mean) * (v - mean);
  var /= static_cast<double>(n);
  if (!(var > 0)) return 1.0;
  // g = 1 + 2 Σ_τ (1 − τ/n) C(τ), to the first C(τ) ≤ 0 after a few lags.
  // Past kDenseLags (a ramp's C stays positive for half the samples) the lags
  // grow apart, the sum between them by the trapezoidal rule: O(n √n) at most.
  constexpr std::size_t kMinLag = 3;
  auto term = [&](std::size_t lag) {  // (1 − τ/n) C(τ)
    double c = 0.0;
    for (std::size_t i = 0; i + lag < n; ++i) c += (x[i] - mean) * (x[i + lag] - mean);
    c /= static_cast<double>(n - lag) * var;
    return c * (1.0 - static_cast<double>(lag) / static_cast<double>(n));
  };
  double g = 1.0, previous = 0.0;
  std::size_t previous_lag = 0;
  for (std::size_t lag = 1, step = 1; lag < n - 1; lag += step) {
    const double now = term(lag);
    if (now <= 0.0 && lag > kMinLag) break;
    const auto gap = static_cast<double>(lag - previous_lag);
    g += 2.0 * (gap == 1.0 ? now : 0.5 * (now + previous) * gap);
    previous = now;
    previous_lag = lag;
    if (lag >= kDenseLags) ++step;
  }
  return std::max(1.0, g);
}

double settled_from(std::span<const double> t, std::span<const double> f) {
  check_sizes(t, f, "settled_from");
  if (t.size() < 2) return t.empty() ? 0.0 : t.front();
  const auto slips = find_block_slips(t, f);
  if (slips.size() >= 3) {
    // Batches are whole cycles, onset to onset: cut the leading cycles whose
    // means bias the rest, keeping two cycles at least.
    std::vector<double> onsets;
    for (const auto& s : slips) onsets.push_back(s.onset);
    const std::size_t cycles = onsets.size() - 1;
    const Antiderivative integral(t, f);
    const std::size_t d = mser(std::min(cycles / 2, cycles - 2), [&](std::size_t cut) {
      const std::vector<double> rest(onsets.begin() + static_cast<long>(cut), onsets.end());
      return batch_mean(integral, rest).error;
    });
    return onsets[d];
  }
  if (!slips.empty()) return slips.front().onset;
  // No block slip: MSER-5 over the whole trace.
  constexpr std::size_t kBatch = 5;
  const std::size_t batches = t.size() / kBatch;
  if (batches < 4) return t.front();
  std::vector<double> mean(batches);
  for (std::size_t b = 0; b < batches; ++b) {
    double s = 0.0;
    for (std::size_t i = 0; i < kBatch; ++i) s += f[b * kBatch + i];
    mean[b] = s / kBatch;
  }
  std::vector<double> s1(batches + 1, 0.0), s2(batches + 1, 0.0);  // suffix sums
  for (std::size_t b = batches; b-- > 0;) {
    s1[b] = s1[b + 1] + mean[b];
    s2[b] = s2[b + 1] + mean[b] * mean[b];
  }
  const std::size_t d = mser(batches / 2, [&](std::size_t cut) {
    const double k = static_cast<double>(batches - cut);
    return std::max(0.0, s2[cut] - s1[cut] * s1[cut] / k) / (k * k);
  });
  return t[d * kBatch];
}

const char* to_string(Regime r) {
  switch (r) {
    case Regime::stick_slip:
      return "stick-slip";
    case Regime::steady_sliding:
      return "steady sliding";
    case Regime::loading:
      return "loading";
    case Regime::unsettled:
      return "unsettled";
    case Regime::undersampled:
      return "undersampled";
    case Regime::not_driven:
      return "not driven";
  }
  return "?";
}

FrictionWindow analyse_window(std::span<const double> t_all, std::span<const double> f_all,
                              double t_from, bool driven) {
  check_sizes(t_all, f_all, "analyse_window");
  std::size_t first = 0;
  while (first < t_all.size() && t_all[first] < t_from) ++first;
  const auto t = t_all.subspan(first), f = f_all.subspan(first);

  FrictionWindow w;
  w.samples = static_cast<long>(t.size());
  const Antiderivative integral(t, f);
  w.mean = t.size() >= 2   ? integral.over(t.front(), t.back()) / (t.back() - t.front())
           : t.size() == 1 ? f.front()
                           : kNaN;
  w.error = kNaN;
  w.spread = t.size() >= 2 ? relative_spread(t, f, t_from) : kNaN;
  fit_line(t, f, w.regime);

  // Block slips of the whole trace; those whose onset is in the window bound its cycles.
  w.block_slips = find_block_slips(t_all, f_all);
  const auto& slips = w.block_slips;
  std::vector<double> onsets;
  for (const auto& s : slips)
    if (!t.empty() && s.onset >= t.front() && s.onset <= t.back()) onsets.push_back(s.onset);
  CycleMean& c = w.cycles;
  c.block_slips = static_cast<long>(onsets.size());
  c.period = kNaN;
  c.error = kNaN;
  c.mean = w.mean;
  c.from = t.empty() ? t_from : t.front();
  c.to = t.empty() ? t_from : t.back();
  if (onsets.size() >= 2) {
    const BatchMean whole = batch_mean(integral, onsets);
    c.mean = whole.mean;
    c.error = whole.error;
    c.from = onsets.front();
    c.to = onsets.back();
    c.period = (c.to - c.from) / static_cast<double>(onsets.size() - 1);
  }

  // The window mean's error: its pieces between block slips as batches (the
  // partial cycles at its ends weigh in as they bias it), or F's autocorrelation.
  if (!slips.empty() && t.size() >= 2) {
    std::vector<double> bounds = {t.front()};
    for (double o : onsets)
      if (o > bounds.back() && o < t.back()) bounds.push_back(o);
    bounds.push_back(t.back());
    w.error = batch_mean(integral, bounds).error;
    w.error_from = "block cycles";
  } else if (slips.empty() && w.samples >= kMinSamples) {
    const double sd = w.spread * w.mean;
    w.error = std::abs(sd) * std::sqrt(statistical_inefficiency(f) / static_cast<double>(t.size()));
    w.error_from = "autocorrelation";
  }
  if (std::isnan(w.error)) w.error_from = "";

  WindowRegime& r = w.regime;
  const double interval =
      t.size() >= 2 ? (t.back() - t.front()) / static_cast<double>(t.size() - 1) : kNaN;
  if (!driven) {
    r.kind = Regime::not_driven;
  } else if (w.samples < kMinSamples) {
    r.kind = Regime::undersampled;
  } else if (std::abs(w.spread) <= kSteadySpread) {
    // Steady first: a constant F's tiny wiggles are neither slips nor a ramp.
    r.kind = Regime::steady_sliding;
  } else if (!slips.empty() && t.front() < slips.front().onset) {
    r.kind = Regime::loading;
    r.transient_ends = slips.front().onset;
  } else if (slips.empty() && r.drift > 0 && r.trend_share >= kRampShare) {
    r.kind = Regime::loading;
  } else if (onsets.size() >= 2) {
    r.kind = c.period / interval < kMinSamplesPerCycle ? Regime::undersampled : Regime::stick_slip;
  } else if (slips.empty()) {
    // Small slips, no block slip: F fluctuates about its mean. Trusted past
    // the transient, unless what precedes the settled part biases the mean.
    const double settled = settled_from(t_all, f_all);
    bool biased = false;
    if (t.front() < settled && !std::isnan(w.error)) {
      const double later = integral.over(settled, t.back()) / (t.back() - settled);
      biased = std::abs(w.mean - later) > 2.0 * w.error;
    }
    if (biased) {
      r.kind = Regime::loading;
      r.transient_ends = settled;
    } else {
      r.kind = downward_crossings(f, w.mean) >= 2 ? Regime::stick_slip : Regime::unsettled;
    }
  } else {
    r.kind = Regime::unsettled;
  }
  return w;
}

}  // namespace stickslip
