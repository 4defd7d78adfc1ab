#include "stickslip/analysis/compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <ostream>
#include <system_error>
#include <utility>

#include "stickslip/core/json_number.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/writers.hpp"

namespace stickslip {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

[[noreturn]] void fail(const fs::path& file, const std::string& why) {
  throw CompareError(file.string() + ": " + why);
}

std::string sci(double x, int digits = 2) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*e", digits, x);
  return buf;
}

// The run's summary.json (output/summary.hpp), or CompareError naming the
// directory or file and what is wrong with it.
Summary run_summary(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) fail(dir, "no such directory");
  if (!fs::is_directory(dir, ec)) fail(dir, "not a directory");
  const fs::path file = dir / kSummaryFile;
  if (!fs::exists(file, ec)) fail(file, "no such file (not a run's output directory?)");
  std::optional<Summary> s;
  try {
    s = read_summary(dir);
  } catch (const OutputError& e) {
    throw CompareError(e.what());
  }
  if (!s) fail(file, "not complete JSON (a run still writing it, or killed while it did)");
  return *s;
}

// B's column interpolated linearly onto A's times where both runs have data.
TraceDiff compare_column(const std::string& name, const TraceTable& a, std::size_t ca,
                         const TraceTable& b, std::size_t cb) {
  TraceDiff d;
  d.column = name;
  if (a.t.empty() || b.t.empty()) {
    d.l2 = d.max_abs = d.rel_l2 = kNaN;
    return d;
  }
  const double lo = std::max(a.t.front(), b.t.front()), hi = std::min(a.t.back(), b.t.back());
  const auto& va = a.values[ca];
  const auto& vb = b.values[cb];
  double sum_d2 = 0.0, sum_a2 = 0.0;
  std::size_t j = 0;  // B's segment [t_j, t_j+1]; A's times increase, so it only moves forward
  for (std::size_t i = 0; i < a.t.size(); ++i) {
    const double t = a.t[i];
    if (t < lo || t > hi) continue;
    // t in [t_j, t_j+1); on B's own grid point w = 0, so identical runs
    // compare exactly equal.
    while (j + 1 < b.t.size() && b.t[j + 1] <= t) ++j;
    double vb_at = vb[j];
    if (j + 1 < b.t.size() && t != b.t[j]) {
      const double w = (t - b.t[j]) / (b.t[j + 1] - b.t[j]);
      vb_at = (1.0 - w) * vb[j] + w * vb[j + 1];
    }
    const double diff = vb_at - va[i];
    sum_d2 += diff * diff;
    sum_a2 += va[i] * va[i];
    // NaN must not vanish in std::max: it has to make the comparison fail.
    d.max_abs = std::isnan(diff) ? diff : std::max(d.max_abs, std::abs(diff));
    ++d.samples;
  }
  if (d.samples == 0) {
    d.l2 = d.max_abs = d.rel_l2 = kNaN;
    return d;
  }
  d.l2 = std::sqrt(sum_d2 / static_cast<double>(d.samples));
  d.rms_a = std::sqrt(sum_a2 / static_cast<double>(d.samples));
  return d;
}

void compare_traces(CompareResult& r) {
  r.traces_a = has_run_table(r.dir_a, "traces");
  r.traces_b = has_run_table(r.dir_b, "traces");
  if (!r.traces_a || !r.traces_b) return;
  const TraceTable a = read_run_table(r.dir_a, "traces");
  const TraceTable b = read_run_table(r.dir_b, "traces");
  for (std::size_t ca = 0; ca < a.columns.size(); ++ca) {
    const auto it = std::find(b.columns.begin(), b.columns.end(), a.columns[ca]);
    if (it == b.columns.end()) {
      r.columns_only_a.push_back(a.columns[ca]);
      continue;
    }
    r.traces.push_back(
        compare_column(a.columns[ca], a, ca, b, static_cast<std::size_t>(it - b.columns.begin())));
  }
  for (const auto& name : b.columns)
    if (std::find(a.columns.begin(), a.columns.end(), name) == a.columns.end())
      r.columns_only_b.push_back(name);
  // Each column is judged against the velocity scale of the whole run (the
  // largest RMS of A's columns), so a component that is ~0 by symmetry (vy in
  // a case driven along x) does not turn rounding noise into a failure.
  double scale = 0.0;
  for (const TraceDiff& d : r.traces)
    if (d.samples > 0 && std::isfinite(d.rms_a)) scale = std::max(scale, d.rms_a);
  for (TraceDiff& d : r.traces) {
    if (d.samples == 0) continue;
    if (scale > 0.0)
      d.rel_l2 = d.l2 / scale;
    else
      d.rel_l2 = d.l2 == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
  }
  for (const TraceDiff& d : r.traces) {
    if (d.samples == 0)
      r.failures.push_back("traces " + d.column + ": no common times");
    else if (!(d.rel_l2 <= r.rtol))
      r.failures.push_back("traces " + d.column + ": relative L2 difference " + sci(d.rel_l2) +
                           " > rtol " + sci(r.rtol));
  }
}

void compare_events(CompareResult& r) {
  r.events_a = has_run_table(r.dir_a, "events");
  r.events_b = has_run_table(r.dir_b, "events");
  if (!r.events_a || !r.events_b) return;
  // (contact, kind) → times, in time order; the map orders contacts, then slip
  // before stick.
  using Groups = std::map<std::pair<int, int>, std::vector<double>>;
  auto group = [](const std::vector<Event>& events) {
    Groups g;
    for (const Event& e : events) g[{e.contact, static_cast<int>(e.kind)}].push_back(e.t);
    for (auto& [key, times] : g) std::stable_sort(times.begin(), times.end());
    return g;
  };
  const Groups a = group(read_run_events(r.dir_a));
  const Groups b = group(read_run_events(r.dir_b));
  Groups keys = a;
  for (const auto& [key, times] : b) keys[key];
  static const std::vector<double> none;
  for (const auto& [key, unused] : keys) {
    const auto ia = a.find(key), ib = b.find(key);
    const auto& ta = ia == a.end() ? none : ia->second;
    const auto& tb = ib == b.end() ? none : ib->second;
    EventDiff d;
    d.contact = key.first;
    d.kind = static_cast<EventKind>(key.second);
    const std::size_t n = std::min(ta.size(), tb.size());
    d.matched = static_cast<long>(n);
    d.unmatched_a = static_cast<long>(ta.size() - n);
    d.unmatched_b = static_cast<long>(tb.size() - n);
    d.max_dt = d.mean_dt = n ? 0.0 : kNaN;
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double dt = std::abs(tb[i] - ta[i]);
      d.max_dt = std::isnan(dt) ? dt : std::max(d.max_dt, dt);
      sum += dt;
    }
    if (n) d.mean_dt = sum / static_cast<double>(n);
    r.events.push_back(d);

    const std::string name =
        "events contact " + std::to_string(d.contact) + " " + std::string(to_string(d.kind));
    if (n && !(d.max_dt <= r.event_tolerance))
      r.failures.push_back(name + ": max |dt| " + sci(d.max_dt) +
                           " s > rtol × t_end = " + sci(r.event_tolerance) + " s");
    if (d.unmatched_a || d.unmatched_b)
      r.failures.push_back(name + ": " + std::to_string(d.unmatched_a + d.unmatched_b) +
                           " without partner (A has " + std::to_string(ta.size()) + ", B " +
                           std::to_string(tb.size()) + ")");
  }
}

}  // namespace

CompareResult compare_runs(const fs::path& dir_a, const fs::path& dir_b, double rtol) {
  if (!(rtol >= 0.0) || !std::isfinite(rtol))
    throw CompareError("--rtol: must be a finite number >= 0, got " + sci(rtol));
  CompareResult r;
  r.dir_a = dir_a;
  r.dir_b = dir_b;
  r.rtol = rtol;
  const Summary a = run_summary(dir_a);
  const Summary b = run_summary(dir_b);
  r.mu_a = a.mu;
  r.mu_b = b.mu;
  r.t_end_a = a.t_end;
  r.event_tolerance = rtol * a.t_end;
  if (a.mu != 0.0)
    r.mu_rel_diff = std::abs(b.mu - a.mu) / std::abs(a.mu);
  else
    r.mu_rel_diff = b.mu == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
  if (!(r.mu_rel_diff <= rtol))
    r.failures.push_back("mu: relative difference " + sci(r.mu_rel_diff) + " > rtol " + sci(rtol));
  try {
    compare_traces(r);
    compare_events(r);
  } catch (const OutputError& e) {  // a table that cannot be read: this command's bad input
    throw CompareError(e.what());
  }
  return r;
}

nlohmann::json to_json(const CompareResult& r) {
  nlohmann::json columns = nlohmann::json::array();
  for (const TraceDiff& d : r.traces)
    columns.push_back({{"column", d.column},
                       {"samples", d.samples},
                       {"l2", number_or_null(d.l2)},
                       {"max_abs", number_or_null(d.max_abs)},
                       {"rel_l2", number_or_null(d.rel_l2)}});
  nlohmann::json groups = nlohmann::json::array();
  for (const EventDiff& d : r.events)
    groups.push_back({{"contact", d.contact},
                      {"kind", std::string(to_string(d.kind))},
                      {"matched", d.matched},
                      {"max_dt", number_or_null(d.max_dt)},
                      {"mean_dt", number_or_null(d.mean_dt)},
                      {"unmatched_a", d.unmatched_a},
                      {"unmatched_b", d.unmatched_b}});
  return {{"dir_a", r.dir_a.string()},
          {"dir_b", r.dir_b.string()},
          {"rtol", r.rtol},
          {"pass", r.pass()},
          {"mu",
           {{"a", number_or_null(r.mu_a)},
            {"b", number_or_null(r.mu_b)},
            {"rel_diff", number_or_null(r.mu_rel_diff)}}},
          {"t_end_a", number_or_null(r.t_end_a)},
          {"event_tolerance", number_or_null(r.event_tolerance)},
          {"traces",
           {{"in_a", r.traces_a},
            {"in_b", r.traces_b},
            {"columns", columns},
            {"only_in_a", r.columns_only_a},
            {"only_in_b", r.columns_only_b}}},
          {"events", {{"in_a", r.events_a}, {"in_b", r.events_b}, {"groups", groups}}},
          {"failures", r.failures}};
}

void print_report(std::ostream& out, const CompareResult& r) {
  out << "A: " << r.dir_a.string() << "\nB: " << r.dir_b.string() << "  (rtol " << sci(r.rtol)
      << ")\n";
  char line[160];
  std::snprintf(line, sizeof line, "mu      A %.6g  B %.6g  relative difference %.2e\n", r.mu_a,
                r.mu_b, r.mu_rel_diff);
  out << line;

  auto absent = [](bool in_a, bool in_b) {
    return !in_a && !in_b ? "in neither run" : in_a ? "only in A" : "only in B";
  };
  out << "traces  ";
  if (!r.traces_a || !r.traces_b) {
    out << "traces table " << absent(r.traces_a, r.traces_b) << ": not compared\n";
  } else if (r.traces.empty()) {
    out << "no common columns\n";
  } else {
    // The worst column; NaN counts as worst.
    const auto worst = std::max_element(
        r.traces.begin(), r.traces.end(), [](const TraceDiff& x, const TraceDiff& y) {
          return !std::isnan(x.rel_l2) && (std::isnan(y.rel_l2) || x.rel_l2 < y.rel_l2);
        });
    std::snprintf(line, sizeof line,
                  "%zu common columns, worst %s: relative L2 %.2e, max |diff| %.2e\n",
                  r.traces.size(), worst->column.c_str(), worst->rel_l2, worst->max_abs);
    out << line;
  }
  if (!r.columns_only_a.empty() || !r.columns_only_b.empty())
    out << "        " << r.columns_only_a.size() << " columns only in A, "
        << r.columns_only_b.size() << " only in B (not compared)\n";

  out << "events  ";
  if (!r.events_a || !r.events_b) {
    out << "events table " << absent(r.events_a, r.events_b) << ": not compared\n";
  } else {
    long matched = 0, unmatched = 0;
    double max_dt = 0.0;
    for (const EventDiff& d : r.events) {
      matched += d.matched;
      unmatched += d.unmatched_a + d.unmatched_b;
      if (d.matched) max_dt = std::isnan(d.max_dt) ? d.max_dt : std::max(max_dt, d.max_dt);
    }
    std::snprintf(line, sizeof line,
                  "%ld matched, max |dt| %.2e s (tolerance %.2e s), %ld unmatched\n", matched,
                  max_dt, r.event_tolerance, unmatched);
    out << line;
  }

  if (r.pass()) {
    out << "PASS: all differences within tolerance\n";
  } else {
    out << "FAIL: " << r.failures.size() << " difference(s) exceed the tolerance\n";
    for (const auto& f : r.failures) out << "  " << f << '\n';
  }
}

int compare_command(const fs::path& dir_a, const fs::path& dir_b, double rtol,
                    const fs::path& json_file, std::ostream& out, std::ostream& err) {
  try {
    const CompareResult r = compare_runs(dir_a, dir_b, rtol);
    print_report(out, r);
    const fs::path file = json_file.empty() ? dir_b / "compare.json" : json_file;
    try {
      write_json_atomically(file, to_json(r));
    } catch (const OutputError& e) {
      throw CompareError(e.what());
    } catch (const fs::filesystem_error& e) {
      throw CompareError(file.string() + ": cannot write: " + e.code().message());
    }
    out << "written " << file.string() << '\n';
    return r.pass() ? 0 : 1;
  } catch (const CompareError& e) {
    err << "error: " << e.what() << '\n';
    return 2;
  }
}

}  // namespace stickslip
