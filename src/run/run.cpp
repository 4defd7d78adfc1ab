#include "stickslip/run/run.hpp"

#include <sundials/sundials_config.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <optional>

#include "stickslip/analysis/compare.hpp"
#include "stickslip/analysis/cycles.hpp"
#include "stickslip/analysis/events.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/model/contacts.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/version.hpp"

namespace stickslip {
namespace {

using Clock = std::chrono::steady_clock;

volatile std::sig_atomic_t g_stop_signal = 0;
extern "C" void request_stop(int sig) {
  g_stop_signal = sig;
}

// How often (wall time) the CSV outputs are flushed, so a crash keeps them.
constexpr double kFlushSeconds = 2.0;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// A fixed-step run whose energy audit is off by this much has blown up.
constexpr double kDivergedResidual = 0.5;
// The energy-audit bound of a fixed-step run, which has no rtol: the
// default tolerances' bound, 100 × 1e-6.
constexpr double kFixedStepAuditBound = 1e-4;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Progress on stderr, only when it is a terminal: simulated time, percent,
// steps, elapsed and estimated remaining wall time, twice a second at most.
class Progress {
 public:
  Progress(bool enabled, double t_end)
      : enabled_(enabled && isatty(STDERR_FILENO)), t_end_(t_end) {}
  void update(double t, long steps) {
    if (!enabled_) return;
    const double elapsed = seconds_since(start_);
    if (elapsed - last_ < 0.5) return;
    last_ = elapsed;
    const double fraction = t / t_end_;
    const double remaining = fraction > 0 ? elapsed * (1 - fraction) / fraction : 0.0;
    std::fprintf(stderr, "\r  t = %.4e s  %5.1f %%  %ld steps  %.1f s elapsed, ~%.1f s left   ", t,
                 100 * fraction, steps, elapsed, remaining);
    shown_ = true;
  }
  ~Progress() {
    if (shown_) std::fprintf(stderr, "\r%90s\r", "");
  }

 private:
  bool enabled_;
  double t_end_;
  Clock::time_point start_ = Clock::now();
  double last_ = 0.0;
  bool shown_ = false;
};

std::vector<int> selected(ContactSelection which, const std::vector<int>& ids,
                          std::size_t contacts) {
  if (which == ContactSelection::list) return ids;
  std::vector<int> all;
  if (which == ContactSelection::all)
    for (std::size_t i = 0; i < contacts; ++i) all.push_back(static_cast<int>(i));
  return all;
}

// Elastic travel time between two bottom sites at the transverse sound speed,
// over the shortest periodic separation: the default coincidence window.
double travel_time(const System& s, const Contact& a, const Contact& b) {
  auto wrap = [](int d, int n) {
    d = std::abs(d) % n;
    return std::min(d, n - d);
  };
  const double dx = wrap(a.ix - b.ix, s.nx()), dy = wrap(a.iy - b.iy, s.ny());
  return std::hypot(dx, dy) * s.spacing() / std::sqrt(s.g1());
}

}  // namespace

void install_stop_handlers() {
  std::signal(SIGINT, request_stop);
  std::signal(SIGTERM, request_stop);
}

std::filesystem::path output_dir_for(const Case& c, const std::filesystem::path& out_flag) {
  if (!out_flag.empty()) return out_flag;
  if (!c.output.dir.empty()) return c.output.dir;
  return std::filesystem::path("out") / c.source.stem();
}

RunResult run_case(const Case& c, const RunOptions& options) {
  const auto wall_start = Clock::now();
  const auto& dir = options.out_dir;
  // A restart continues from the checkpoint: same case, same code, and every
  // output cut back to the checkpoint's time so no row is duplicated.
  std::optional<Checkpoint> resume;
  if (options.restart) {
    if (std::filesystem::exists(dir / "summary.json"))
      throw OutputError(dir.string() + ": the run there has finished (summary.json exists)");
    resume = read_checkpoint(dir);
    if (restart_identity(resume->case_json) != restart_identity(to_json(c)))
      throw OutputError((dir / kCheckpointFile).string() +
                        ": written for a different case; restart with the case file it came from");
    if (resume->git_commit != kGitCommit)
      throw OutputError((dir / kCheckpointFile).string() + ": written by code version " +
                        resume->git_commit + ", this is " + kGitCommit);
    for (const char* name :
         {"friction.csv", "traces.csv", "events.csv", "steps.csv", "signals.csv"})
      keep_rows_up_to(dir / name, resume->t);
  } else {
    prepare_output_dir(dir, options.overwrite);
  }
  const System system(c, place_contacts(c.lattice, c.interface));
  const auto& contacts = system.contacts();

  if (!resume) {
    std::ofstream out(dir / "contacts.csv");
    out << "id,ix,iy,v_star\n";
    char line[96];
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      std::snprintf(line, sizeof line, "%zu,%d,%d,%.17g\n", i, contacts[i].ix, contacts[i].iy,
                    contacts[i].v_star);
      out << line;
    }
  }
  // Only what the case asks for is recorded: traces, events, steps.
  auto open_csv = [&](const char* name, const std::vector<std::string>& header) {
    return resume ? CsvWriter::append(dir / name) : CsvWriter(dir / name, header);
  };
  CsvWriter friction = open_csv("friction.csv", {"t", "F_f", "mu_inst"});
  const auto traced = selected(c.output.traces, c.output.trace_ids, contacts.size());
  const auto watched = selected(c.output.events, c.output.event_ids, contacts.size());
  std::optional<CsvWriter> traces, events_csv, steps_csv, signals;
  // The acoustic signal is a second difference of the contact impulse over the
  // output times: the last two rows' (t, impulse), read back on a restart.
  std::vector<std::array<double, 2>> impulse_rows;
  if (c.output.signals) {
    if (resume) {
      const TraceTable written = read_traces_csv(dir / "signals.csv");
      const auto& impulses = written.values[1];  // t, block_velocity, contact_impulse, acoustic
      for (std::size_t k = written.t.size() - std::min<std::size_t>(2, written.t.size());
           k < written.t.size(); ++k)
        impulse_rows.push_back({written.t[k], impulses[k]});
    }
    signals.emplace(
        open_csv("signals.csv", {"t", "block_velocity", "contact_impulse", "acoustic"}));
    signals->full_precision();  // the impulse is differenced twice
  }
  if (!traced.empty()) {
    std::vector<std::string> header{"t"};
    for (int id : traced) {
      header.push_back("vx_" + std::to_string(id));
      header.push_back("vy_" + std::to_string(id));
    }
    traces.emplace(open_csv("traces.csv", header));
  }
  if (!watched.empty())
    events_csv.emplace(open_csv("events.csv", {"t", "contact", "kind", "speed", "force"}));
  IntegratorOptions integrator_options;
  integrator_options.watched_contacts = watched;
  // Between output times too, every kPollSteps steps: flush the CSVs now and
  // then, and stop at once when SIGINT or SIGTERM arrived.
  auto last_flush = Clock::now();
  std::function<void()> flush_all;
  integrator_options.poll = [&] {
    if (seconds_since(last_flush) > kFlushSeconds) {
      flush_all();
      last_flush = Clock::now();
    }
    return g_stop_signal != 0;
  };
  if (c.output.steps) {
    steps_csv.emplace(open_csv("steps.csv", {"t", "h", "error"}));
    integrator_options.on_step = [&](const StepRecord& r) {
      const double row[2] = {r.h, r.error};
      steps_csv->row(r.t, row);
    };
  }

  // The pair whose synchronization is reported: the only two contacts, or the
  // only two watched ones. Their x-velocities are kept in memory only if traced.
  std::optional<std::pair<int, int>> pair;
  if (watched.size() == 2) pair = {watched[0], watched[1]};
  std::vector<double> pair_t, pair_va, pair_vb;
  const bool pair_traced = pair &&
                           std::find(traced.begin(), traced.end(), pair->first) != traced.end() &&
                           std::find(traced.begin(), traced.end(), pair->second) != traced.end();

  std::vector<double> y0(static_cast<std::size_t>(system.size()));
  system.initial_state(c.run.initial, y0);
  std::vector<double> y = resume ? resume->state : y0;
  const SolverStats stats_before = resume ? resume->stats : SolverStats{};
  SolverParams solver = c.solver;  // max_steps counts the steps before a restart too
  solver.max_steps = std::max(1L, c.solver.max_steps - stats_before.steps);
  auto integrator =
      make_integrator(system, solver, y, c.run.t_end, integrator_options, resume ? resume->t : 0.0);
  auto total_stats = [&] {
    SolverStats s = stats_before;
    return s += integrator->stats();
  };

  std::vector<bool> slipping_at_start(contacts.size());
  for (std::size_t i = 0; i < contacts.size(); ++i) slipping_at_start[i] = system.slipping(i, y0);
  std::vector<Event> events;
  if (resume && events_csv) events = read_events_csv(dir / "events.csv");
  if (resume && pair_traced) {
    const TraceTable table = read_traces_csv(dir / "traces.csv");
    auto column = [&](int id) {
      const auto name = "vx_" + std::to_string(id);
      return table.values[static_cast<std::size_t>(
          std::find(table.columns.begin(), table.columns.end(), name) - table.columns.begin())];
    };
    pair_t = table.t;
    pair_va = column(pair->first);
    pair_vb = column(pair->second);
  }
  char line[160];
  auto record_events = [&](double t) {
    const auto roots = integrator->roots();
    for (std::size_t k = 0; k < roots.size(); ++k) {
      if (roots[k] == 0) continue;
      const auto id = static_cast<std::size_t>(watched[k]);
      const auto v = system.contact_velocity(id, y);
      Event e{t, watched[k], roots[k] > 0 ? EventKind::slip : EventKind::stick,
              std::hypot(v[0], v[1]), system.contact_force(id, y)};
      events.push_back(e);
      std::snprintf(line, sizeof line, "%.15g,%d,%s,%.10g,%.10g", e.t, e.contact,
                    e.kind == EventKind::slip ? "slip" : "stick", e.speed, e.force);
      events_csv->line(line);
    }
  };
  // Integrates to `target`, stopping at every stick/slip transition on the
  // way. Returns the time reached: `target`, or earlier on a stop request.
  auto advance_to = [&](double target) {
    for (;;) {
      const double t = integrator->advance(target, y);
      if (!watched.empty()) record_events(t);
      if (t >= target || g_stop_signal) return t;
    }
  };

  const double normal_force = system.normal_force();
  std::vector<double> trace_row(2 * traced.size());
  auto record = [&](double t) {
    const double ff = system.friction_force(t, y);
    const double row[2] = {ff, ff / normal_force};
    friction.row(t, row);
    if (signals) {
      const double impulse = system.contact_impulse(t, y);
      double acoustic = std::nan("");
      if (impulse_rows.size() == 2) {
        const auto [t0, j0] = impulse_rows[0];
        const auto [t1, j1] = impulse_rows[1];
        acoustic = ((impulse - j1) / (t - t1) - (j1 - j0) / (t1 - t0)) / (0.5 * (t - t0));
        impulse_rows.erase(impulse_rows.begin());
      }
      impulse_rows.push_back({t, impulse});
      const double values[3] = {system.block_velocity(y), impulse, acoustic};
      signals->row(t, values);
    }
    if (traces) {
      for (std::size_t k = 0; k < traced.size(); ++k) {
        const auto v = system.contact_velocity(static_cast<std::size_t>(traced[k]), y);
        trace_row[2 * k] = v[0];
        trace_row[2 * k + 1] = v[1];
      }
      traces->row(t, trace_row);
    }
    if (pair_traced) {
      pair_t.push_back(t);
      pair_va.push_back(system.contact_velocity(static_cast<std::size_t>(pair->first), y)[0]);
      pair_vb.push_back(system.contact_velocity(static_cast<std::size_t>(pair->second), y)[0]);
    }
  };
  // A run that goes wrong stops here, keeping every row written so far; its
  // μ is never reported. Fixed-step runs can blow up without any error test,
  // so for them the energy audit is watched too.
  auto check_health = [&](double t) {
    for (double v : y)
      if (!std::isfinite(v)) {
        char msg[160];
        std::snprintf(msg, sizeof msg, "non-finite state at t = %.9g s (%s)", t,
                      c.solver.step > 0 ? "the fixed step is too large" : "the solution diverged");
        throw IntegrationError(msg);
      }
    if (c.solver.step > 0 && t >= 10 * c.output.interval) {
      const double residual = system.energy_residual(t, y, y0);
      if (!(std::abs(residual) < kDivergedResidual)) {
        char msg[200];
        std::snprintf(msg, sizeof msg,
                      "energy audit diverged at t = %.9g s (relative residual %.3g): the fixed "
                      "step %.3g s is too large",
                      t, residual, c.solver.step);
        throw IntegrationError(msg);
      }
    }
  };

  flush_all = [&] {
    friction.flush();
    if (traces) traces->flush();
    if (events_csv) events_csv->flush();
    if (steps_csv) steps_csv->flush();
    if (signals) signals->flush();
  };

  if (!resume) record(0.0);
  Progress progress(!options.quiet, c.run.t_end);
  const double t_end = c.run.t_end, t_avg = c.run.average_from, dt = c.output.interval;
  const long outputs = static_cast<long>(std::ceil(t_end / dt - 1e-9));
  double impulse_at_avg = resume ? resume->impulse_at_average : (t_avg == 0.0 ? 0.0 : std::nan(""));
  const std::int64_t impulse = system.quadrature_index(System::friction_impulse);
  const double every = c.run.checkpoint_every;
  double next_checkpoint = every > 0 ? (resume ? resume->t : 0.0) + every : kInfinity;
  auto checkpoint = [&](double t, long k) {
    flush_all();
    write_checkpoint(dir, {t, k, impulse_at_avg, y, total_stats(), to_json(c), kGitCommit});
  };
  // A stop request ends the run at time t, after output row k: checkpoint
  // there (between output times if the request came mid-interval).
  auto stop_if_requested = [&](double t, long k) {
    if (!g_stop_signal) return;
    const int sig = g_stop_signal;
    checkpoint(t, k);
    throw Interrupted{sig, t};
  };
  try {
    for (long k = resume ? resume->output_index + 1 : 1; k <= outputs; ++k) {
      const double t_out = std::min(t_end, static_cast<double>(k) * dt);
      if (std::isnan(impulse_at_avg) && t_avg <= t_out) {
        // μ averages from t_avg exactly: stop there (interpolated, like every output).
        const double t = advance_to(t_avg);
        if (t < t_avg) {
          check_health(t);
          stop_if_requested(t, k - 1);
        }
        impulse_at_avg = y[impulse];
      }
      const double t = advance_to(t_out);
      check_health(t);  // before the row is written: no NaN ever reaches an output
      if (t < t_out) stop_if_requested(t, k - 1);
      record(t_out);
      progress.update(t_out, total_stats().steps);
      stop_if_requested(t_out, k);
      if (t_out >= next_checkpoint && k < outputs) {
        checkpoint(t_out, k);
        next_checkpoint += every;
      }
      if (seconds_since(last_flush) > kFlushSeconds) {
        flush_all();
        last_flush = Clock::now();
      }
    }
  } catch (...) {
    flush_all();
    throw;
  }

  RunResult result;
  result.contacts = contacts.size();
  result.theta = system.coverage();
  result.normal_force = normal_force;
  result.mu = (y[impulse] - impulse_at_avg) / ((t_end - t_avg) * normal_force);
  result.energy_residual = system.energy_residual(t_end, y, y0);
  result.stats = total_stats();
  // μ over whole cycles of F_f as well (analysis/cycles.hpp): from the output
  // samples, so it costs nothing during the run.
  friction.flush();
  const TraceTable series = read_traces_csv(dir / "friction.csv");  // t, F_f, mu_inst
  std::optional<CycleMean> cycles;
  std::optional<double> spread;
  if (std::count_if(series.t.begin(), series.t.end(), [&](double t) { return t >= t_avg; }) >= 2) {
    cycles = whole_cycle_mean(series.t, series.values[0], t_avg);
    spread = relative_spread(series.t, series.values[0], t_avg);
  }
  // A result whose energy audit is off by more than the tolerances can
  // explain is not reported (docs/STABILITY.md: |R| ≈ 0.01–10 × rtol in sound
  // runs; fixed steps are held to the default's bound).
  const double audit_bound = c.solver.audit_bound > 0 ? c.solver.audit_bound
                             : c.solver.step > 0      ? kFixedStepAuditBound
                                                      : 100 * c.solver.rtol;
  // Below one absolute energy tolerance the residual of an adaptive run is
  // tolerance noise, not a relative error (a short run whose work done is
  // tiny: the integrals themselves are only controlled to that level). A
  // fixed step controls nothing, so nothing is excused.
  const double work = y[system.quadrature_index(System::work_in)];
  const double energy_atol =
      c.solver.step > 0
          ? 0.0
          : absolute_tolerances(system, c.solver)[system.quadrature_index(System::work_in)];
  if (!(std::abs(result.energy_residual * work) <= audit_bound * std::abs(work) + energy_atol)) {
    char msg[400];
    std::snprintf(msg, sizeof msg,
                  "energy audit failed at t = %.9g s: relative residual %.3g exceeds the bound "
                  "%.3g ([solver] audit_bound, default 100 x rtol, %g for a fixed step); no "
                  "result is reported. %s",
                  t_end, result.energy_residual, audit_bound, kFixedStepAuditBound,
                  c.solver.step > 0 ? "Use a smaller [solver] step."
                                    : "Tighten [solver] rtol or atol_velocity.");
    throw IntegrationError(msg);
  }
  result.wall_seconds = seconds_since(wall_start);

  nlohmann::json solver_description = integrator->description();
  if (c.solver.method == Method::automatic)
    solver_description["chosen_by"] = choose_method(system, c.solver).reason;
  nlohmann::json summary = {
      {"mu", result.mu},
      {"mu_whole_cycles", cycles ? nlohmann::json{{"mu", cycles->mean / normal_force},
                                                  {"from", cycles->from},
                                                  {"to", cycles->to},
                                                  {"crossings", cycles->crossings}}
                                 : nlohmann::json()},
      {"F_f_spread", spread ? nlohmann::json(*spread) : nlohmann::json()},
      {"theta", result.theta},
      {"F_N", normal_force},
      {"contacts", result.contacts},
      {"t_end", t_end},
      {"average_from", t_avg},
      {"wall_seconds", result.wall_seconds},
      {"energy_residual", result.energy_residual},
      {"energy_audit_bound", audit_bound},
      {"steady_sliding_mu", system.steady_sliding_mu()},
      {"solver", solver_description},
      {"solver_stats", result.stats},
      {"provenance", {{"git_commit", kGitCommit}, {"sundials_version", SUNDIALS_VERSION}}},
      {"case", to_json(c)},
  };
  if (!watched.empty()) {
    nlohmann::json per_contact = nlohmann::json::array();
    for (int id : watched)
      per_contact.push_back(to_json(contact_statistics(
          events, id, slipping_at_start[static_cast<std::size_t>(id)], t_avg, t_end)));
    summary["events"] = {
        {"count", events.size()}, {"window", {t_avg, t_end}}, {"per_contact", per_contact}};
  }
  if (pair) {
    const double window = travel_time(system, contacts[static_cast<std::size_t>(pair->first)],
                                      contacts[static_cast<std::size_t>(pair->second)]);
    // Only the averaging window is correlated: the start from rest is a transient.
    summary["synchronization"] = to_json(synchronization(events, pair->first, pair->second, window,
                                                         t_avg, t_end, pair_t, pair_va, pair_vb));
  }
  if (c.output.final_state) {
    // For comparing runs state by state (bench/work_precision.py).
    CsvWriter state(dir / "final_state.csv",
                    {"t", "ix", "iy", "iz", "u_x", "u_y", "u_z", "w_x", "w_y", "w_z"});
    state.full_precision();
    std::array<double, 9> row{};
    for (int iz = 0; iz < system.nz(); ++iz)
      for (int iy = 0; iy < system.ny(); ++iy)
        for (int ix = 0; ix < system.nx(); ++ix) {
          const std::int64_t n = system.node(ix, iy, iz);
          row = {double(ix), double(iy), double(iz)};
          for (int k = 0; k < 3; ++k) {
            row[3 + k] = y[static_cast<std::size_t>(system.u_index(n, k))];
            row[6 + k] = y[static_cast<std::size_t>(system.w_index(n, k))];
          }
          state.row(t_end, row);
        }
  }
  write_json_atomically(dir / "summary.json", summary);
  // The run is complete: its checkpoint has nothing left to resume.
  std::filesystem::remove(dir / kCheckpointFile);
  return result;
}

}  // namespace stickslip
