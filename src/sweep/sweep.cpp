#include "stickslip/sweep/sweep.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <sstream>

#include "stickslip/case/reader.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/tables.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/version.hpp"

extern char** environ;

namespace stickslip {
namespace {

namespace fs = std::filesystem;

volatile std::sig_atomic_t g_sweep_signal = 0;
extern "C" void request_sweep_stop(int sig) {
  g_sweep_signal = sig;
}

// The last non-empty line of a point's run.log: why it failed.
std::string last_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

std::string csv_field(std::string s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// 10 digits; empty where not defined.
std::string number(double x) {
  if (!std::isfinite(x)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", x);
  return buf;
}
std::string number(const std::optional<double>& x) {
  return x ? number(*x) : std::string();
}

// sweep.csv's columns after the point's name and its axes' values, in order,
// the synchronization's only when some point has one. regime: what F_f does
// in the window (core/cycles.hpp); μ is a friction coefficient only in
// "stick-slip" and "steady sliding".
// mu_error: the standard error of the point's own μ (from its window,
// summary.json's mu_error), not a spread over seeds; average_from: where its
// window started (found by the run with run.average_from = "auto").
constexpr const char* kResultColumns[] = {"status",
                                          "mu",
                                          "mu_error",
                                          "mu_whole_cycles",
                                          "mu_whole_cycles_error",
                                          "average_from",
                                          "regime",
                                          "F_f_spread",
                                          "theta",
                                          "contacts",
                                          "F_N",
                                          "energy_residual",
                                          "slips",
                                          "mean_recurrence",
                                          "slipping_fraction"};
constexpr const char* kSyncColumns[] = {"slip_rate_ratio",     "lag_mean",   "lag_min",  "lag_max",
                                        "coincident_fraction", "xcorr_peak", "xcorr_lag"};
constexpr const char* kRunColumns[] = {"steps",        "rhs_explicit", "rhs_implicit",
                                       "wall_seconds", "git_commit",   "error"};

// One row of a CSV table, a field per column of its header, filled by column
// name; fields left unset are empty.
class CsvRow {
 public:
  explicit CsvRow(const std::vector<std::string>& columns)
      : columns_(columns), fields_(columns.size()) {}
  std::string& operator[](std::size_t i) { return fields_.at(i); }
  std::string& operator[](std::string_view name) {
    const auto it = std::find(columns_.begin(), columns_.end(), name);
    if (it == columns_.end()) throw std::logic_error("no column " + std::string(name));
    return fields_[static_cast<std::size_t>(it - columns_.begin())];
  }
  friend std::ostream& operator<<(std::ostream& out, const CsvRow& row) {
    for (std::size_t i = 0; i < row.fields_.size(); ++i) out << (i ? "," : "") << row.fields_[i];
    return out << '\n';
  }

 private:
  const std::vector<std::string>& columns_;
  std::vector<std::string> fields_;
};

// Starts `stickslip run` for one point, its output in <dir>/run.log.
pid_t spawn_point(const Sweep& sweep, const SweepPoint& p, const fs::path& dir, const fs::path& exe,
                  bool restart, bool any_version, int threads) {
  std::vector<std::string> args = {exe.string(), "run", sweep.base_case.string(), "--quiet"};
  if (threads > 0) args.insert(args.end(), {"--threads", std::to_string(threads)});
  if (restart) {
    args.insert(args.end(), {"--restart", dir.string()});
    if (any_version) args.emplace_back("--any-version");
  } else {
    args.insert(args.end(), {"--out", dir.string(), "--overwrite"});
  }
  for (const auto& o : p.overrides) args.insert(args.end(), {"--set", o});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  const std::string log = (dir / "run.log").string();
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | (restart ? O_APPEND : O_TRUNC), 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int err = posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (err != 0) throw OutputError(exe.string() + ": cannot start a point: " + std::strerror(err));
  return pid;
}

}  // namespace

Shard parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  auto whole = [](const std::string& s, int& value) {
    if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos)
      return false;
    value = std::stoi(s);
    return true;
  };
  Shard shard;
  if (slash == std::string::npos || !whole(text.substr(0, slash), shard.index) ||
      !whole(text.substr(slash + 1), shard.count) || shard.count < 1 || shard.index >= shard.count)
    throw CaseError("--shard " + text +
                    ": expected i/n with whole numbers 0 <= i < n (the points whose index is i "
                    "modulo n; for a Slurm array --array=0-(n-1))");
  return shard;
}

const char* to_string(PointState s) {
  switch (s) {
    case PointState::absent:
      return "not run";
    case PointState::incomplete:
      return "incomplete";
    case PointState::finished:
      return "finished";
    case PointState::stale:
      return "stale";
    case PointState::failed:
      return "failed";
  }
  return "?";
}

PointState point_state(const SweepPoint& point, const fs::path& dir, std::string* why,
                       bool any_version) {
  std::optional<Summary> summary;
  try {
    summary = read_summary(dir);
  } catch (const OutputError& e) {
    // Complete but not a summary this code writes: an older version's.
    if (why) *why = e.what();
    return PointState::stale;
  }
  if (!summary) {
    if (fs::exists(dir / "failed")) return PointState::failed;
    return fs::exists(dir / csv_file_name(run_table::kFriction)) || fs::exists(dir / kHdf5File)
               ? PointState::incomplete
               : PointState::absent;
  }
  if (!any_version) {
    // Every attempt's version: a restart with --any-version may have mixed them.
    std::vector<std::string> versions{summary->git_commit};
    for (const auto& segment : summary->segments) versions.push_back(segment.git_commit);
    for (const auto& version : versions)
      if (version != kGitCommit) {
        if (why) *why = "computed by code version " + version + ", this is " + kGitCommit;
        return PointState::stale;
      }
  }
  if (const auto differences = case_differences(summary->case_json, point.c);
      !differences.empty()) {
    if (why)
      *why = "computed for a different case (the base case or [set] changed: " +
             describe(differences, "point's summary.json") + ")";
    return PointState::stale;
  }
  return PointState::finished;
}

std::size_t write_sweep_tables(const Sweep& sweep, const std::vector<SweepPoint>& points,
                               const fs::path& out_dir, bool any_version) {
  std::vector<std::optional<Summary>> summaries;
  std::vector<PointState> states;
  bool any_sync = false;
  for (const auto& p : points) {
    const fs::path dir = out_dir / p.name;
    states.push_back(point_state(p, dir, nullptr, any_version));
    summaries.push_back(states.back() == PointState::finished ? read_summary(dir) : std::nullopt);
    any_sync = any_sync || (summaries.back() && summaries.back()->synchronization);
  }

  std::vector<std::string> columns{"point"};
  for (const auto& a : sweep.axes) columns.push_back(a.key);
  columns.insert(columns.end(), std::begin(kResultColumns), std::end(kResultColumns));
  if (any_sync) columns.insert(columns.end(), std::begin(kSyncColumns), std::end(kSyncColumns));
  columns.insert(columns.end(), std::begin(kRunColumns), std::end(kRunColumns));
  std::ostringstream table;
  for (std::size_t c = 0; c < columns.size(); ++c) table << (c ? "," : "") << columns[c];
  table << '\n';

  std::size_t finished = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    CsvRow row(columns);
    row[0] = csv_field(p.name);
    for (std::size_t a = 0; a < p.labels.size(); ++a) row[1 + a] = csv_field(p.labels[a]);
    const fs::path dir = out_dir / p.name;
    if (!summaries[i]) {
      const PointState state = states[i];
      row["status"] = to_string(state);
      if (state == PointState::failed) row["error"] = csv_field(last_line(dir / "run.log"));
      table << row;
      continue;
    }
    ++finished;
    const Summary& s = *summaries[i];
    // Slip statistics over the watched contacts: total slips, mean recurrence
    // and slipping fraction averaged over the contacts that define them.
    long slips = 0;
    double recurrence = 0, fraction = 0;
    int n_rec = 0, n_frac = 0;
    if (s.events)
      for (const auto& c : s.events->per_contact) {
        slips += c.slips;
        if (std::isfinite(c.mean_recurrence)) recurrence += c.mean_recurrence, ++n_rec;
        if (std::isfinite(c.slipping_fraction)) fraction += c.slipping_fraction, ++n_frac;
      }
    row["status"] = "finished";
    row["mu"] = number(s.mu);
    if (std::isfinite(s.mu_error)) row["mu_error"] = number(s.mu_error);
    if (const auto& c = s.mu_whole_cycles) {
      row["mu_whole_cycles"] = number(c->mu);
      if (std::isfinite(c->error)) row["mu_whole_cycles_error"] = number(c->error);
    }
    row["average_from"] = number(s.average_from);
    if (s.regime) row["regime"] = to_string(s.regime->kind);
    row["F_f_spread"] = number(s.F_f_spread);
    row["theta"] = number(s.theta);
    row["contacts"] = std::to_string(s.contacts);
    row["F_N"] = number(s.F_N);
    row["energy_residual"] = number(s.energy_residual);
    if (s.events) row["slips"] = std::to_string(slips);
    if (n_rec) row["mean_recurrence"] = number(recurrence / n_rec);
    if (n_frac) row["slipping_fraction"] = number(fraction / n_frac);
    if (const auto& y = s.synchronization) {
      row["slip_rate_ratio"] = number(y->slip_rate_ratio);
      row["lag_mean"] = number(y->lag_mean);
      row["lag_min"] = number(y->lag_min);
      row["lag_max"] = number(y->lag_max);
      row["coincident_fraction"] = number(y->coincident_fraction);
      row["xcorr_peak"] = number(y->xcorr_peak);
      row["xcorr_lag"] = number(y->xcorr_lag);
    }
    const SolverStats& st = s.solver_stats;
    row["steps"] = std::to_string(st.steps);
    row["rhs_explicit"] = std::to_string(st.rhs_explicit);
    row["rhs_implicit"] = std::to_string(st.rhs_implicit);
    row["wall_seconds"] = number(s.wall_seconds);
    row["git_commit"] = s.git_commit;
    table << row;
  }
  write_atomically(out_dir / kSweepFile, [&](std::ostream& out) { out << table.str(); });

  // μ over `average_over` for every combination of the other axes.
  std::size_t avg_axis = sweep.axes.size();
  for (std::size_t i = 0; i < sweep.axes.size(); ++i)
    if (sweep.axes[i].key == sweep.average_over) avg_axis = i;
  struct Group {
    std::vector<double> mu, mu_cycles, theta;       // of the finished points
    std::vector<double> mu_error, mu_cycles_error;  // their own errors (NaN where none)
    long untrusted = 0;  // finished points whose μ is no friction coefficient (loading, ...)
  };
  std::map<std::vector<std::size_t>, Group> groups;  // axis value indices -> points
  std::vector<std::vector<std::size_t>> order;
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::vector<std::size_t> key;
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
      if (a == avg_axis) continue;
      const auto& labels = sweep.axes[a].labels;
      key.push_back(static_cast<std::size_t>(
          std::find(labels.begin(), labels.end(), points[i].labels[a]) - labels.begin()));
    }
    if (!groups.count(key)) order.push_back(key);
    auto& g = groups[key];
    if (summaries[i] && std::isfinite(summaries[i]->mu)) {
      g.mu.push_back(summaries[i]->mu);
      g.theta.push_back(summaries[i]->theta);
      g.mu_error.push_back(summaries[i]->mu_error);
      if (const auto& r = summaries[i]->regime; r && !r->mu_trusted()) ++g.untrusted;
      if (const auto& cycles = summaries[i]->mu_whole_cycles) {
        g.mu_cycles.push_back(cycles->mu);
        g.mu_cycles_error.push_back(cycles->error);
      }
    }
  }
  auto num = [](double x) { return std::isfinite(x) ? number(x) : std::string(); };
  // mean, sample standard deviation and standard error, empty where undefined
  auto statistics = [&](const std::vector<double>& xs) {
    const auto n = static_cast<double>(xs.size());
    double mean = 0, var = 0;
    for (double x : xs) mean += x / n;
    for (double x : xs) var += (x - mean) * (x - mean);
    const double sd = xs.size() > 1 ? std::sqrt(var / (n - 1)) : NAN;
    return (xs.empty() ? "" : num(mean)) + ',' + num(sd) + ',' + num(sd / std::sqrt(n));
  };
  std::ostringstream summary;
  bool first = true;
  for (std::size_t a = 0; a < sweep.axes.size(); ++a)
    if (a != avg_axis) summary << (first ? "" : ",") << sweep.axes[a].key, first = false;
  summary << (first ? "" : ",")
          << "theta_mean,mu_mean,mu_std,mu_sem,count,"
             "mu_whole_cycles_mean,mu_whole_cycles_std,mu_whole_cycles_sem,untrusted,"
             "mu_runs_error,mu_whole_cycles_runs_error\n";
  // mu_sem is the seeds' spread over √count; mu_runs_error is what the
  // points' own error bars give mu_mean (√Σ e² / count), only when every
  // finished point has one; mu_whole_cycles_runs_error the same of μ over
  // whole cycles.
  auto runs_error = [&](const std::vector<double>& errors) {
    double sum = 0;
    for (double e : errors) {
      if (!std::isfinite(e)) return std::string();
      sum += e * e;
    }
    return errors.empty() ? std::string()
                          : num(std::sqrt(sum) / static_cast<double>(errors.size()));
  };
  for (const auto& key : order) {
    std::size_t k = 0;
    for (std::size_t a = 0; a < sweep.axes.size(); ++a)
      if (a != avg_axis) summary << csv_field(sweep.axes[a].labels[key[k++]]) << ',';
    const Group& g = groups[key];
    double theta = 0;
    for (double t : g.theta) theta += t / static_cast<double>(g.theta.size());
    summary << (g.theta.empty() ? "" : num(theta)) << ',' << statistics(g.mu) << ',' << g.mu.size()
            << ','
            // Only when every finished point has it: never a mean over fewer points than count.
            << (g.mu_cycles.size() == g.mu.size() ? statistics(g.mu_cycles) : ",,") << ','
            << g.untrusted << ',' << runs_error(g.mu_error) << ','
            << (g.mu_cycles.size() == g.mu.size() ? runs_error(g.mu_cycles_error) : "") << '\n';
  }
  write_atomically(out_dir / kSweepSummaryFile, [&](std::ostream& out) { out << summary.str(); });
  return finished;
}

SweepOutcome run_sweep(const Sweep& sweep, const std::vector<SweepPoint>& points,
                       const SweepOptions& options, std::ostream& log) {
  SweepOutcome outcome;
  outcome.points = points.size();
  // Stale results are never mixed in, nor silently replaced.
  std::vector<std::size_t> todo;
  std::string stale;
  std::size_t n_stale = 0;
  for (const auto& p : points) {
    std::string why;
    const PointState state = point_state(p, options.out_dir / p.name, &why, options.any_version);
    if (state == PointState::finished) {
      ++outcome.skipped;
      continue;
    }
    if (state == PointState::stale && !options.overwrite) {
      if (n_stale++ == 0) stale = (options.out_dir / p.name).string() + ": " + why;
      continue;
    }
    if (p.index % static_cast<std::size_t>(options.ranks) == static_cast<std::size_t>(options.rank))
      todo.push_back(p.index);
  }
  if (n_stale > 0)
    throw OutputError(
        stale +
        (n_stale > 1 ? " (and " + std::to_string(n_stale - 1) + " more points)" : std::string()) +
        "; pass --overwrite to recompute them (or --any-version to keep those of another code "
        "version)");

  struct Running {
    std::size_t index;
    bool restart;
  };
  std::map<pid_t, Running> running;
  g_sweep_signal = 0;
  // Without SA_RESTART, so a signal cuts the pause between polls short.
  struct sigaction stop = {}, old_int = {}, old_term = {};
  stop.sa_handler = request_sweep_stop;
  sigemptyset(&stop.sa_mask);
  sigaction(SIGINT, &stop, &old_int);
  sigaction(SIGTERM, &stop, &old_term);
  std::size_t next = 0;
  bool forwarded = false;
  auto start = [&](std::size_t index, bool restart) {
    const auto& p = points[index];
    const fs::path dir = options.out_dir / p.name;
    fs::create_directories(dir);
    fs::remove(dir / "failed");
    running[spawn_point(sweep, p, dir, options.executable, restart, options.any_version,
                        options.threads_per_point)] = {index, restart};
  };
  while (next < todo.size() || !running.empty()) {
    while (!g_sweep_signal && next < todo.size() &&
           running.size() < static_cast<std::size_t>(std::max(1, options.jobs))) {
      const fs::path dir = options.out_dir / points[todo[next]].name;
      // A point stopped earlier continues from its checkpoint; one with a
      // summary (stale, to recompute) starts afresh, even if it kept its
      // final state.
      start(todo[next++], fs::exists(dir / kCheckpointFile) && !fs::exists(dir / kSummaryFile));
    }
    // SIGINT or SIGTERM sent to the sweep alone (a notebook's interrupt, kill,
    // a scheduler before its time limit) is passed on to the running points,
    // which checkpoint and stop. A terminal's Ctrl-C reaches them through the
    // process group as well; a second request changes nothing for them.
    if (g_sweep_signal && !forwarded) {
      for (const auto& [child, r] : running) kill(child, g_sweep_signal);
      forwarded = true;
    }
    if (running.empty()) break;  // stopped before the points left were started
    int status = 0;
    // Polled, not blocking: a signal arriving between the check above and a
    // blocking wait would not end the wait, and the points would run on.
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid == 0) {
      const timespec pause = {0, 20'000'000};  // 20 ms; a signal cuts it short
      nanosleep(&pause, nullptr);
      continue;
    }
    if (pid < 0) {
      if (errno == EINTR) continue;
      break;
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const Running r = it->second;
    running.erase(it);
    const auto& p = points[r.index];
    const fs::path dir = options.out_dir / p.name;
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (code == 2 && r.restart && !g_sweep_signal) {
      // The checkpoint is from another code version or case: start afresh.
      start(r.index, false);
      continue;
    }
    ++outcome.ran;
    std::string line = "[" + std::to_string(outcome.ran) + "/" + std::to_string(todo.size()) +
                       "] " + p.name + ": ";
    if (code == 0) {
      const auto s = read_summary(dir);
      char buf[128];
      std::snprintf(buf, sizeof buf, "mu = %s (%.1f s)", s ? mu_text(*s).c_str() : "?",
                    s ? s->wall_seconds : NAN);
      line += buf;
      // As the point's own run says on its stderr: a μ that is no friction
      // coefficient is named where the sweep reports it.
      if (s && s->regime && !s->regime->mu_trusted())
        line += std::string(", not a friction coefficient (") + to_string(s->regime->kind) + ")";
    } else if (code == 130 || code == 143) {
      line += "interrupted; a checkpoint is kept";
    } else {
      ++outcome.failed;
      std::ofstream(dir / "failed") << code << '\n';
      line += "failed (exit " + std::to_string(code) + "): " + last_line(dir / "run.log");
    }
    log << line << std::endl;
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  outcome.interrupted_by = g_sweep_signal;
  return outcome;
}

}  // namespace stickslip
