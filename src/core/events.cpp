#include "stickslip/core/events.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "stickslip/core/json_number.hpp"

namespace stickslip {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The cross-correlation looks for the peak within ±kMaxXcorrLag. The elastic
// travel time between the contacts of Fig. 10 is a few µs (shear waves at
// ~100 m/s over 7 a = 0.7 mm), while one stick-slip cycle lasts ~0.3 ms
// (MODEL.md §13): 0.1 ms covers every plausible delay without reaching the
// neighbouring cycle's slip. The lag is further capped at a quarter of the
// samples so every lag is computed from at least three quarters of the window.
constexpr double kMaxXcorrLag = 1e-4;  // [s]

void check_window(double t_from, double t_to) {
  if (!(t_from < t_to))  // also rejects NaN
    throw std::invalid_argument("event window: need t_from < t_to");
}

// The contact's events, in time order (stable: simultaneous events keep the
// order they were recorded in).
std::vector<Event> events_of(std::span<const Event> events, int contact) {
  std::vector<Event> mine;
  for (const Event& e : events)
    if (e.contact == contact) mine.push_back(e);
  std::stable_sort(mine.begin(), mine.end(),
                   [](const Event& x, const Event& y) { return x.t < y.t; });
  return mine;
}

std::vector<double> slip_times(std::span<const Event> events, int contact, double t_from,
                               double t_to) {
  std::vector<double> times;
  for (const Event& e : events_of(events, contact))
    if (e.kind == EventKind::slip && e.t >= t_from && e.t <= t_to) times.push_back(e.t);
  return times;
}

struct XcorrPeak {
  double peak = 0.0;
  double lag = 0.0;
};

// Normalized cross-correlation of a and b sampled at t (uniform), over the
// samples with t in [t_from, t_to]. Both signals have their window mean
// removed; at lag k, a_i is paired with b_{i+k} over the samples where both
// exist, and the sum is divided by the root of the two signals' energies over
// those same samples. That makes it a cosine similarity in [−1, 1] whatever
// the overlap, so a train and the same train delayed by k samples give exactly
// 1 at lag k (a full-window normalization would give (n−k)/n). A positive lag
// means b lags a. The peak is the largest correlation (not the largest
// magnitude: anticorrelation is not synchronization); on ties, the smallest
// |lag| wins. Lags at which either signal is constant are skipped; if all are,
// there is no peak. Cost: O(n · max lag).
std::optional<XcorrPeak> cross_correlation(std::span<const double> t, std::span<const double> a,
                                           std::span<const double> b, double t_from, double t_to) {
  const auto first = std::lower_bound(t.begin(), t.end(), t_from);
  const auto last = std::upper_bound(t.begin(), t.end(), t_to);
  const long lo = first - t.begin();
  const long n = last - first;
  if (n < 2) return std::nullopt;
  const double dt = (t[static_cast<std::size_t>(lo + n - 1)] - t[static_cast<std::size_t>(lo)]) /
                    static_cast<double>(n - 1);
  if (!(dt > 0.0)) return std::nullopt;
  const long max_lag =
      std::min(static_cast<long>(std::floor(kMaxXcorrLag / dt * (1.0 + 1e-12))), n / 4);

  std::vector<double> x(static_cast<std::size_t>(n)), y(static_cast<std::size_t>(n));
  double mean_x = 0.0, mean_y = 0.0;
  for (long i = 0; i < n; ++i) {
    x[static_cast<std::size_t>(i)] = a[static_cast<std::size_t>(lo + i)];
    y[static_cast<std::size_t>(i)] = b[static_cast<std::size_t>(lo + i)];
    mean_x += x[static_cast<std::size_t>(i)];
    mean_y += y[static_cast<std::size_t>(i)];
  }
  mean_x /= static_cast<double>(n);
  mean_y /= static_cast<double>(n);
  for (auto& v : x) v -= mean_x;
  for (auto& v : y) v -= mean_y;

  std::optional<XcorrPeak> best;
  auto try_lag = [&](long k) {
    double xy = 0.0, xx = 0.0, yy = 0.0;
    for (long i = std::max(0L, -k); i < std::min(n, n - k); ++i) {
      const double xi = x[static_cast<std::size_t>(i)], yi = y[static_cast<std::size_t>(i + k)];
      xy += xi * yi;
      xx += xi * xi;
      yy += yi * yi;
    }
    if (!(xx > 0.0 && yy > 0.0)) return;
    const double r = std::clamp(xy / std::sqrt(xx * yy), -1.0, 1.0);
    if (!best || r > best->peak) best = XcorrPeak{r, static_cast<double>(k) * dt};
  };
  // 0, +1, −1, +2, −2, …: with a strict ">" the smallest |lag| wins ties.
  try_lag(0);
  for (long k = 1; k <= max_lag; ++k) {
    try_lag(k);
    try_lag(-k);
  }
  return best;
}

}  // namespace

std::string_view to_string(EventKind kind) {
  return kind == EventKind::slip ? "slip" : "stick";
}

std::optional<EventKind> parse_event_kind(std::string_view text) {
  if (text == "slip") return EventKind::slip;
  if (text == "stick") return EventKind::stick;
  return std::nullopt;
}

ContactEventStats contact_statistics(std::span<const Event> events, int contact,
                                     bool slipping_at_start, double t_from, double t_to) {
  check_window(t_from, t_to);
  const std::vector<Event> mine = events_of(events, contact);
  ContactEventStats s;
  s.contact = contact;

  // State at t_from: each event sets it (a repeated event of the same kind
  // changes nothing), so only the last one before t_from matters.
  bool slipping = slipping_at_start;
  std::size_t i = 0;
  for (; i < mine.size() && mine[i].t < t_from; ++i) slipping = mine[i].kind == EventKind::slip;

  // Time spent slipping in the window, including a slip already under way at
  // t_from and one still under way at t_to.
  double slipping_time = 0.0, since = t_from;
  std::vector<double> slips;
  double duration_sum = 0.0;
  long durations = 0;
  for (std::size_t j = i; j < mine.size() && mine[j].t <= t_to; ++j) {
    const Event& e = mine[j];
    if (slipping) slipping_time += e.t - since;
    since = e.t;
    slipping = e.kind == EventKind::slip;
    if (e.kind != EventKind::slip) continue;
    slips.push_back(e.t);
    // Duration: to the first stick after this slip, if it comes by t_to; a
    // slip cut off by the window's end would bias the mean short.
    const auto stick = std::find_if(mine.begin() + static_cast<std::ptrdiff_t>(j) + 1, mine.end(),
                                    [](const Event& x) { return x.kind == EventKind::stick; });
    if (stick != mine.end() && stick->t <= t_to) {
      duration_sum += stick->t - e.t;
      ++durations;
    }
  }
  if (slipping) slipping_time += t_to - since;

  s.slips = static_cast<long>(slips.size());
  s.slipping_fraction = slipping_time / (t_to - t_from);
  s.mean_slip_duration = durations ? duration_sum / static_cast<double>(durations) : kNaN;
  if (slips.size() < 2) {
    s.mean_recurrence = s.std_recurrence = kNaN;
  } else {
    // Population standard deviation (divide by the number of intervals): it is
    // defined from a single interval (then 0), and the intervals are the whole
    // record for this window, not a sample of a larger one.
    const double m = static_cast<double>(slips.size() - 1);
    s.mean_recurrence = (slips.back() - slips.front()) / m;
    double var = 0.0;
    for (std::size_t k = 1; k < slips.size(); ++k) {
      const double d = slips[k] - slips[k - 1] - s.mean_recurrence;
      var += d * d;
    }
    s.std_recurrence = std::sqrt(var / m);
  }
  return s;
}

Synchronization synchronization(std::span<const Event> events, int contact_a, int contact_b,
                                double window, double t_from, double t_to,
                                std::span<const double> t, std::span<const double> va,
                                std::span<const double> vb) {
  check_window(t_from, t_to);
  if (va.size() != t.size() || vb.size() != t.size())
    throw std::invalid_argument("synchronization: traces t, va, vb differ in length");
  Synchronization s;
  s.contact_a = contact_a;
  s.contact_b = contact_b;
  s.window = window;

  const std::vector<double> a = slip_times(events, contact_a, t_from, t_to);
  // b's slips at any time: the nearest partner of a slip near the window's
  // edge may lie just outside it.
  const std::vector<double> b_all =
      slip_times(events, contact_b, -std::numeric_limits<double>::infinity(),
                 std::numeric_limits<double>::infinity());
  const auto b_in_window =
      std::count_if(b_all.begin(), b_all.end(), [&](double x) { return x >= t_from && x <= t_to; });

  s.slip_rate_ratio =
      a.empty() ? kNaN : static_cast<double>(b_in_window) / static_cast<double>(a.size());
  s.lag_mean = s.lag_min = s.lag_max = kNaN;
  s.coincident_fraction = a.empty() ? kNaN : 0.0;
  if (!a.empty() && !b_all.empty()) {
    double sum = 0.0;
    long coincident = 0;
    s.lag_min = std::numeric_limits<double>::infinity();
    s.lag_max = -std::numeric_limits<double>::infinity();
    for (double ta : a) {
      // Nearest slip of b: the first at or after ta, or the one before it; on
      // a tie the earlier one (negative lag) is taken.
      const auto after = std::lower_bound(b_all.begin(), b_all.end(), ta);
      double lag = std::numeric_limits<double>::infinity();
      if (after != b_all.end()) lag = *after - ta;
      if (after != b_all.begin() && ta - *(after - 1) <= std::abs(lag)) lag = *(after - 1) - ta;
      sum += lag;
      s.lag_min = std::min(s.lag_min, lag);
      s.lag_max = std::max(s.lag_max, lag);
      if (std::abs(lag) <= window) ++coincident;
    }
    s.lag_mean = sum / static_cast<double>(a.size());
    s.coincident_fraction = static_cast<double>(coincident) / static_cast<double>(a.size());
  }

  if (!t.empty()) {
    if (const auto peak = cross_correlation(t, va, vb, t_from, t_to)) {
      s.xcorr_peak = peak->peak;
      s.xcorr_lag = peak->lag;
    }
  }
  return s;
}

nlohmann::json to_json(const ContactEventStats& s) {
  return {{"contact", s.contact},
          {"slips", s.slips},
          {"mean_recurrence", number_or_null(s.mean_recurrence)},
          {"std_recurrence", number_or_null(s.std_recurrence)},
          {"mean_slip_duration", number_or_null(s.mean_slip_duration)},
          {"slipping_fraction", number_or_null(s.slipping_fraction)}};
}

nlohmann::json to_json(const Synchronization& s) {
  return {{"contact_a", s.contact_a},
          {"contact_b", s.contact_b},
          {"slip_rate_ratio", number_or_null(s.slip_rate_ratio)},
          {"lag_mean", number_or_null(s.lag_mean)},
          {"lag_min", number_or_null(s.lag_min)},
          {"lag_max", number_or_null(s.lag_max)},
          // Not "window": events.window is the averaging interval, this a time.
          {"coincidence_window", number_or_null(s.window)},
          {"coincident_fraction", number_or_null(s.coincident_fraction)},
          {"xcorr_peak", number_or_null(s.xcorr_peak)},
          {"xcorr_lag", number_or_null(s.xcorr_lag)}};
}

}  // namespace stickslip
