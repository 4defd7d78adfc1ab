#include "stickslip/core/cycles.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace stickslip {

namespace {

// ∫ f dt over [a, b] (a ≤ b within the samples), f linear between samples.
double integral(std::span<const double> t, std::span<const double> f, double a, double b) {
  auto at = [&](std::size_t i, double s) {  // f at s in [t_i, t_i+1]
    return f[i] + (f[i + 1] - f[i]) * (s - t[i]) / (t[i + 1] - t[i]);
  };
  double sum = 0.0;
  for (std::size_t i = 0; i + 1 < t.size(); ++i) {
    const double lo = std::max(a, t[i]), hi = std::min(b, t[i + 1]);
    if (hi > lo) sum += 0.5 * (at(i, lo) + at(i, hi)) * (hi - lo);
  }
  return sum;
}

}  // namespace

CycleMean whole_cycle_mean(std::span<const double> t_all, std::span<const double> f_all,
                           double t_from) {
  if (t_all.size() != f_all.size())
    throw std::invalid_argument("whole_cycle_mean: times and values differ in number");
  std::size_t first = 0;
  while (first < t_all.size() && t_all[first] < t_from) ++first;
  const auto t = t_all.subspan(first), f = f_all.subspan(first);
  if (t.size() < 2) throw std::invalid_argument("whole_cycle_mean: fewer than two samples");

  CycleMean r;
  r.from = t.front();
  r.to = t.back();
  const double window_mean = integral(t, f, r.from, r.to) / (r.to - r.from);
  std::vector<double> down;  // times where f falls through the window mean
  for (std::size_t i = 0; i + 1 < t.size(); ++i)
    if (f[i] >= window_mean && f[i + 1] < window_mean)
      down.push_back(t[i] + (f[i] - window_mean) / (f[i] - f[i + 1]) * (t[i + 1] - t[i]));
  r.crossings = static_cast<long>(down.size());
  if (down.size() >= 2 && down.back() > down.front()) {
    r.from = down.front();
    r.to = down.back();
  }
  r.mean = r.from == t.front() && r.to == t.back() ? window_mean
                                                   : integral(t, f, r.from, r.to) / (r.to - r.from);
  return r;
}

double relative_spread(std::span<const double> t, std::span<const double> f, double t_from) {
  if (t.size() != f.size())
    throw std::invalid_argument("relative_spread: times and values differ in number");
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
  }
  return "?";
}

WindowRegime classify_window(std::span<const double> t, std::span<const double> f, double t_from,
                             const CycleMean& cycles, double spread) {
  // Least squares line through the window's samples, in centred sums.
  double n = 0.0, t_mean = 0.0, f_mean = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] >= t_from) {
      n += 1.0;
      t_mean += (t[i] - t_mean) / n;
      f_mean += (f[i] - f_mean) / n;
    }
  double stt = 0.0, stf = 0.0, sff = 0.0;
  double t_first = t_mean, t_last = t_mean;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] >= t_from) {
      stt += (t[i] - t_mean) * (t[i] - t_mean);
      stf += (t[i] - t_mean) * (f[i] - f_mean);
      sff += (f[i] - f_mean) * (f[i] - f_mean);
      t_first = std::min(t_first, t[i]);
      t_last = std::max(t_last, t[i]);
    }
  WindowRegime r;
  const double slope = stt > 0 ? stf / stt : 0.0;
  r.drift = f_mean != 0.0 ? slope * (t_last - t_first) / f_mean : 0.0;
  r.trend_share = stt > 0 && sff > 0 ? std::min(1.0, stf * stf / (stt * sff)) : 0.0;
  // Steady first: a constant F_f's tiny wiggles cross its mean as often as they like.
  if (std::abs(spread) <= kSteadySpread)
    r.kind = Regime::steady_sliding;
  else if (cycles.crossings >= 2)
    r.kind = Regime::stick_slip;
  else if (r.drift > 0 && r.trend_share >= kRampShare)
    r.kind = Regime::loading;
  else
    r.kind = Regime::unsettled;
  return r;
}

}  // namespace stickslip
