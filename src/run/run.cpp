#include "stickslip/run/run.hpp"

#include <signal.h>
#include <sundials/sundials_config.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>

#include "stickslip/case/placement.hpp"
#include "stickslip/core/events.hpp"
#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/integrate/tolerances.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "stickslip/output/recorder.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/run/resume.hpp"
#include "stickslip/run/run_lock.hpp"
#include "stickslip/run/thread_governor.hpp"
#include "stickslip/version.hpp"

namespace stickslip {
namespace {

using Clock = std::chrono::steady_clock;

volatile std::sig_atomic_t g_stop_signal = 0;
extern "C" void request_stop(int sig) {
  g_stop_signal = sig;
}

// How often (wall time) the outputs are flushed, so a crash keeps them.
constexpr double kFlushSeconds = 2.0;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// A fixed-step run whose energy audit is off by this much has blown up.
constexpr double kDivergedResidual = 0.5;

// A callback that hands each record to the recorders that want them
// (`wants`), or none if none does.
template <class Record>
std::function<void(const Record&)> fan_out(const std::vector<std::unique_ptr<Recorder>>& recorders,
                                           bool (Recorder::*wants)() const,
                                           void (Recorder::*give)(const Record&)) {
  std::vector<Recorder*> takers;
  for (const auto& r : recorders)
    if (((*r).*wants)()) takers.push_back(r.get());
  if (takers.empty()) return {};
  return [takers, give](const Record& record) {
    for (Recorder* r : takers) (r->*give)(record);
  };
}

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Progress on stderr, only when it is a terminal: simulated time, percent,
// steps, elapsed and estimated remaining wall time, twice a second at most;
// and to RunOptions::on_progress, if given, at the first output time and
// then as often.
class Progress {
 public:
  Progress(bool enabled, double t_end, std::function<void(double, long)> callback)
      : enabled_(enabled && isatty(STDERR_FILENO)), t_end_(t_end), callback_(std::move(callback)) {}
  void update(double t, long steps) {
    if (!enabled_ && !callback_) return;
    const double elapsed = seconds_since(start_);
    if (callback_ && (!called_ || elapsed - last_called_ >= 0.5)) {
      called_ = true;
      last_called_ = elapsed;
      callback_(t, steps);
    }
    if (!enabled_ || elapsed - last_ < 0.5) return;
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
  std::function<void(double, long)> callback_;
  bool called_ = false;
  double last_called_ = 0.0;
  Clock::time_point start_ = Clock::now();
  double last_ = 0.0;
  bool shown_ = false;
};

}  // namespace

void install_stop_handlers() {
  std::signal(SIGINT, request_stop);
  std::signal(SIGTERM, request_stop);
}

namespace {
// The scopes alive, and the handlers the first of them replaced.
struct StopScopes {
  std::mutex mutex;
  int alive = 0;
  struct sigaction previous_int {};
  struct sigaction previous_term {};
};
StopScopes& stop_scopes() {
  static StopScopes scopes;
  return scopes;
}
}  // namespace

ScopedStopHandlers::ScopedStopHandlers() {
  StopScopes& s = stop_scopes();
  const std::lock_guard lock(s.mutex);
  if (s.alive++ > 0) return;
  g_stop_signal = 0;
  struct sigaction stop {};
  stop.sa_handler = request_stop;
  sigemptyset(&stop.sa_mask);
  sigaction(SIGINT, &stop, &s.previous_int);
  sigaction(SIGTERM, &stop, &s.previous_term);
}

ScopedStopHandlers::~ScopedStopHandlers() {
  StopScopes& s = stop_scopes();
  const std::lock_guard lock(s.mutex);
  if (--s.alive > 0) return;
  sigaction(SIGINT, &s.previous_int, nullptr);
  sigaction(SIGTERM, &s.previous_term, nullptr);
  g_stop_signal = 0;
}

std::filesystem::path output_dir_for(const Case& c, const std::filesystem::path& out_flag) {
  if (!out_flag.empty()) return out_flag;
  if (!c.output.dir.empty()) return c.output.dir;
  return std::filesystem::path("out") / c.source.stem();
}

namespace {
// Files that hold results: the run's own, every recorder's, and what
// `stickslip compare` leaves in a run's directory.
std::vector<std::string> result_files() {
  std::vector<std::string> files = recorder_files();
  for (const char* name : {kSummaryFile, "compare.json", kCheckpointFile}) files.emplace_back(name);
  return files;
}
}  // namespace

// Everything a run holds between its phases, grouped by what it is for. It
// owns all it refers to: a copy of the Case (the caller's may go before the
// run does), the System, and after them what refers to the System (the
// recorders, the integrator), so nothing outlives what it points into.
struct CaseRun::State {
  State(const Case& c, const RunOptions& options);

  // Integrates to `target`, stopping at every stick/slip transition on the
  // way. Returns the time reached: `target`, or earlier on a stop request.
  double advance_to(double target);
  // The integrator returned at t: the recorders learn the state there and
  // its peak speeds (Recorder::reached), then its events.
  void reached(double t);
  void record_events(double t);
  void record(double t);
  // A run that goes wrong stops here, keeping every row written so far; its
  // μ is never reported. Fixed-step runs can blow up without any error test,
  // so for them the energy audit is watched too.
  void check_health(double t) const;
  void checkpoint(double t, long k);
  // A stop request ends the run at time t, after output row k: checkpoint
  // there (between output times if the request came mid-interval).
  void stop_if_requested(double t, long k);
  void flush_all();
  // Lowers the loops' threads while they do not get their cores, and
  // restores them (ThreadGovernor); called between steps.
  void govern_threads();
  SolverStats total_stats() const;
  // Like the solver's counts, a run's cost spans its attempts: a restarted
  // point's wall time is that of every attempt up to its checkpoint.
  double total_wall_seconds() const;

  // What the run is: its case and options (the output directory is
  // options.out_dir), and the signal that asks it to stop (0: none yet).
  const Case c;
  const RunOptions options;
  const std::function<int()> stop_signal;
  const Clock::time_point wall_start = Clock::now();  // its set-up counts too
  // The output directory is this run's until it ends (run/run_lock.hpp):
  // taken before the directory is read or changed, let go after every
  // output below is closed.
  const RunLock lock;
  // The run this one continues, on a restart (open_output_dir decides, before
  // the System is built): its checkpoint, and whether the directory held it
  // finished.
  const ResumePlan plan;
  const std::optional<Checkpoint>& resume = plan.checkpoint;
  const bool extends_finished = plan.kind == ResumePlan::Kind::extend_finished;
  // The model and its state: at t = 0, and now.
  const System system;
  std::vector<double> y0, y;
  // The outputs: the tables, their recorders, the contacts whose events are
  // watched (the integrator's roots, in this order), the last flush.
  std::unique_ptr<TrackedTableStore> tables;
  std::vector<int> watched;
  std::vector<std::unique_ptr<Recorder>> recorders;
  Clock::time_point last_flush = Clock::now();
  // The integration: the case's [solver] resolved once, the solver's counts
  // before a restart, and the integrator.
  ResolvedSolver solver;
  SolverStats stats_before;
  std::unique_ptr<Integrator> integrator;
  // Where the run is: output rows after t = 0 (ceil(t_end / interval)) and
  // the next to record, 1 ... rows; the next checkpoint time (∞ if none).
  long rows = 0;
  long next_row = 1;
  double next_checkpoint = kInfinity;
  // μ averages the friction impulse from run.average_from: its index in the
  // state, and its value there (NaN until the run reaches it).
  std::size_t impulse_index = 0;
  double impulse_at_average = std::nan("");
  std::vector<RunSegment> segments;  // every attempt of the run, this one last
  Progress progress;
  // The run's threads ([solver] threads, resolved as resolve_solver does),
  // handed to the integrator in its options; the governor lowers what its
  // loops use while they do not get their cores.
  std::shared_ptr<ThreadBudget> budget =
      std::make_shared<ThreadBudget>(resolved_threads(c.solver, system.num_nodes()));
  ThreadGovernor threads{budget->threads()};
};

namespace {
// The plan for the output directory (run/resume.hpp), and a fresh start's
// directory made ready: created, or its results removed with --overwrite.
ResumePlan open_output_dir(const Case& c, const RunOptions& options) {
  ResumePlan plan = plan_output_dir(c, {.dir = options.out_dir,
                                        .restart = options.restart,
                                        .overwrite = options.overwrite,
                                        .any_version = options.any_version});
  if (plan.kind == ResumePlan::Kind::fresh)
    prepare_output_dir(options.out_dir, options.overwrite, result_files());
  return plan;
}
}  // namespace

// The stop request of SIGINT and SIGTERM, caught by the handlers above.
int stop_signal_caught() {
  return g_stop_signal;
}

CaseRun::State::State(const Case& c_, const RunOptions& options_)
    : c(c_),
      options(options_),
      stop_signal(options_.stop_signal ? options_.stop_signal : stop_signal_caught),
      // A restart creates no directory: without one, it has nothing to continue.
      lock(options_.out_dir, !options_.restart),
      plan(open_output_dir(c_, options_)),
      system(c_, place_contacts(c_.lattice, c_.interface)),
      progress(!options_.quiet, c_.run.t_end, options_.on_progress) {
  const std::filesystem::path& dir = options.out_dir;
  const auto& contacts = system.contact_set().contacts();
  y0.resize(static_cast<std::size_t>(system.size()));
  system.initial_state(c.run.initial, y0);
  y = resume ? resume->state : y0;

  // Only what the case asks for is recorded (traces, events, steps, signals, ...).
  // How far each table reaches goes into every checkpoint (run/resume.cpp checks it).
  tables = std::make_unique<TrackedTableStore>(
      make_table_store(c.output.format, dir, resume.has_value()),
      resume ? resume->tables : std::map<std::string, double>{});
  if (!resume) {
    // An HDF5 file describes its run by itself (a CSV run has summary.json).
    tables->set_attribute("case", to_json(c).dump());
    tables->set_attribute("git_commit", kGitCommit);
    tables->set_attribute("sundials_version", SUNDIALS_VERSION);
  }
  watched = selected_contacts(c.output.events, c.output.event_ids, contacts.size());
  solver = resolve_solver(system, c.solver);
  recorders =
      make_recorders({c, system, solver.params.method, *tables, dir, y0,
                      resume ? std::optional<double>(resume->t) : std::nullopt,
                      selected_contacts(c.output.traces, c.output.trace_ids, contacts.size()),
                      watched, resume ? resume->recorders : nlohmann::json::object()});

  IntegratorOptions integrator_options;
  integrator_options.watched_contacts = watched;
  integrator_options.threads = budget;
  // Between output times too, every few hundred steps (the method's poll
  // interval, case/methods.hpp): flush the outputs now and then, and stop at
  // once when a stop is requested.
  integrator_options.poll = [this] {
    govern_threads();
    if (seconds_since(last_flush) > kFlushSeconds) {
      flush_all();
      last_flush = Clock::now();
    }
    return stop_signal() != 0;
  };
  // Only recorders that want every step (or attempt) get it: a callback per
  // step costs, so none is set where none asks.
  integrator_options.on_step =
      fan_out<StepRecord>(recorders, &Recorder::wants_steps, &Recorder::step);
  integrator_options.on_attempt =
      fan_out<AttemptRecord>(recorders, &Recorder::wants_attempts, &Recorder::attempt);

  stats_before = resume ? resume->stats : SolverStats{};
  // max_steps counts the steps before a restart too: the integrator's budget is what is left.
  solver.params.max_steps = std::max(1L, c.solver.max_steps - stats_before.steps);
  integrator =
      make_integrator(system, solver, y, c.run.t_end, integrator_options, resume ? resume->t : 0.0);

  if (!resume) record(0.0);
  const double t_end = c.run.t_end, dt = c.output.interval;
  rows = static_cast<long>(std::ceil(t_end / dt - 1e-9));
  // The next row is the first output time after the checkpoint's: a finished
  // run whose t_end is off the output grid wrote its last row there, before
  // output time output_index·dt, which a run continued past it records too.
  const bool off_grid =
      resume && resume->t < static_cast<double>(resume->output_index) * dt * (1 - 1e-9);
  next_row = !resume                         ? 1
             : off_grid && t_end > resume->t ? resume->output_index
                                             : resume->output_index + 1;
  if (c.run.checkpoint_every > 0)
    next_checkpoint = (resume ? resume->t : 0.0) + c.run.checkpoint_every;
  impulse_index = static_cast<std::size_t>(system.quadrature_index(System::friction_impulse));
  if (resume)
    impulse_at_average = resume->impulse_at_average;
  else if (c.run.average_from == 0.0)
    impulse_at_average = 0.0;
  segments = resume ? resume->segments : std::vector<RunSegment>{};
  segments.push_back({resume ? resume->t : 0.0, kGitCommit});
  // Continued past its end, the run is no longer finished: until it is, the
  // directory holds a stopped run (its checkpoint, and rows after t_end).
  if (extends_finished) std::filesystem::remove(dir / kSummaryFile);
}

void CaseRun::State::flush_all() {
  for (const auto& r : recorders) r->flush();
}

SolverStats CaseRun::State::total_stats() const {
  SolverStats s = stats_before;
  return s += integrator->stats();
}

double CaseRun::State::total_wall_seconds() const {
  return (resume ? resume->wall_seconds : 0.0) + seconds_since(wall_start);
}

void CaseRun::State::reached(double t) {
  const auto peaks = integrator->peak_speeds();
  for (const auto& r : recorders) r->reached(t, y, peaks);
}

void CaseRun::State::record_events(double t) {
  const auto roots = integrator->roots();
  for (std::size_t k = 0; k < roots.size(); ++k) {
    if (roots[k] == 0) continue;
    const auto id = static_cast<std::size_t>(watched[k]);
    const auto v = system.contact_set().contact_velocity(id, y);
    const Event e{t, watched[k], roots[k] > 0 ? EventKind::slip : EventKind::stick,
                  std::hypot(v[0], v[1]), system.contact_set().contact_force(id, y)};
    for (const auto& r : recorders) r->event(e, y);
  }
}

void CaseRun::State::govern_threads() {
  budget->set_now(threads.update(seconds_since(wall_start), process_wait_seconds));
}

double CaseRun::State::advance_to(double target) {
  for (;;) {
    govern_threads();
    const double t = integrator->advance(target, y);
    if (!watched.empty()) {
      reached(t);
      record_events(t);
    }
    if (t >= target || stop_signal() != 0) return t;
  }
}

void CaseRun::State::record(double t) {
  for (const auto& r : recorders) r->record(t, y);
}

void CaseRun::State::check_health(double t) const {
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
}

void CaseRun::State::checkpoint(double t, long k) {
  flush_all();
  nlohmann::json saved = nlohmann::json::object();
  for (const auto& r : recorders) r->save(saved);
  write_checkpoint(options.out_dir, {.t = t,
                                     .output_index = k,
                                     .impulse_at_average = impulse_at_average,
                                     .state = y,
                                     .stats = total_stats(),
                                     .wall_seconds = total_wall_seconds(),
                                     .case_json = to_json(c),
                                     .git_commit = kGitCommit,
                                     .segments = segments,
                                     .recorders = std::move(saved),
                                     .tables = tables->last_rows(t)});
}

void CaseRun::State::stop_if_requested(double t, long k) {
  const int sig = stop_signal();
  if (sig == 0) return;
  checkpoint(t, k);
  throw Interrupted{sig, t};
}

CaseRun::CaseRun(const Case& c, const RunOptions& options)
    : s_(std::make_unique<State>(c, options)) {}

CaseRun::~CaseRun() = default;

long CaseRun::next_output() const {
  return s_->next_row;
}

long CaseRun::outputs() const {
  return s_->rows;
}

std::span<const double> CaseRun::state() const {
  return s_->y;
}

const System& CaseRun::system() const {
  return s_->system;
}

void CaseRun::output() {
  State& s = *s_;
  const long k = s.next_row;
  if (k > s.rows) throw std::logic_error("CaseRun::output: past the last output time");
  try {
    const double t_out = std::min(s.c.run.t_end, static_cast<double>(k) * s.c.output.interval);
    const double t_avg = s.c.run.average_from;
    if (std::isnan(s.impulse_at_average) && t_avg <= t_out) {
      // μ averages from t_avg exactly: stop there (interpolated, like every output).
      const double t = s.advance_to(t_avg);
      if (t < t_avg) {
        s.check_health(t);
        s.stop_if_requested(t, k - 1);
      }
      s.impulse_at_average = s.y[s.impulse_index];
    }
    const double t = s.advance_to(t_out);
    s.check_health(t);  // before the row is written: no NaN ever reaches an output
    if (t < t_out) s.stop_if_requested(t, k - 1);
    s.record(t_out);
    s.next_row = k + 1;
    s.progress.update(t_out, s.total_stats().steps);
    s.stop_if_requested(t_out, k);
    if (t_out >= s.next_checkpoint && k < s.rows) {
      s.checkpoint(t_out, k);
      s.next_checkpoint += s.c.run.checkpoint_every;
    }
    if (seconds_since(s.last_flush) > kFlushSeconds) {
      s.flush_all();
      s.last_flush = Clock::now();
    }
  } catch (...) {
    // Keep what was recorded; an output that cannot be flushed now must not
    // hide why the run stopped, but the user must learn that rows were lost.
    try {
      s.flush_all();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "warning: the outputs could not be flushed as the run stopped: %s\n",
                   e.what());
    }
    throw;
  }
}

Summary CaseRun::finish() {
  State& s = *s_;
  if (s.next_row <= s.rows) throw std::logic_error("CaseRun::finish: output times are left");
  const Case& c = s.c;
  const System& system = s.system;
  const auto& y = s.y;
  const double t_end = c.run.t_end, t_avg = c.run.average_from;
  s.flush_all();

  Summary summary;
  const double normal_force = system.normal_force();
  summary.contacts = static_cast<long>(system.contact_set().contacts().size());
  summary.theta = system.coverage();
  summary.F_N = normal_force;
  summary.mu = (y[s.impulse_index] - s.impulse_at_average) / ((t_end - t_avg) * normal_force);
  summary.energy_residual = system.energy_residual(t_end, y, s.y0);
  summary.solver_stats = s.total_stats();
  // A result whose energy audit is off by more than the tolerances can
  // explain is not reported (the bound: resolve_solver).
  const double audit_bound = s.solver.audit_bound;
  // Below one absolute energy tolerance the residual of an adaptive run is
  // tolerance noise, not a relative error (a short run whose work done is
  // tiny: the integrals themselves are only controlled to that level). A
  // fixed step controls nothing, so nothing is excused.
  const double work = y[system.quadrature_index(System::work_in)];
  const double energy_atol =
      c.solver.step > 0
          ? 0.0
          : absolute_tolerances(system, s.solver.params)[system.quadrature_index(System::work_in)];
  if (!(std::abs(summary.energy_residual * work) <= audit_bound * std::abs(work) + energy_atol)) {
    char msg[512];
    std::snprintf(msg, sizeof msg,
                  "energy audit failed at t = %.9g s: relative residual %.3g exceeds the bound "
                  "%.3g ([solver] audit_bound, default 100 x rtol, %g for a fixed step); no "
                  "result is reported. %s",
                  t_end, summary.energy_residual, audit_bound, kFixedStepAuditBound,
                  c.solver.step > 0 ? "Use a smaller [solver] step."
                  : c.solver.atol_velocity > 0 || c.solver.atol_displacement > 0
                      ? "Tighten [solver] rtol and the atol_* the case sets (or leave them "
                        "unset: they follow rtol)."
                      : "Tighten [solver] rtol.");
    throw IntegrationError(msg);
  }
  summary.wall_seconds = s.total_wall_seconds();
  summary.t_end = t_end;
  summary.average_from = t_avg;
  summary.energy_audit_bound = audit_bound;
  summary.energy_audit_allowance = energy_atol / std::abs(work);
  summary.steady_sliding_mu = system.steady_sliding_mu();
  summary.solver = describe_solver(system, s.solver, *s.integrator);
  // This attempt's (a restart's clocks start afresh).
  summary.solver["threads_lowered_seconds"] =
      s.threads.lowered_seconds(seconds_since(s.wall_start));
  summary.git_commit = kGitCommit;
  summary.segments = s.segments;
  summary.sundials_version = SUNDIALS_VERSION;
  summary.case_json = to_json(c);
  for (const auto& r : s.recorders) r->finish(t_end, y, summary);
  // A fixed step has no rtol to be loose.
  summary.warnings = summary_warnings(summary, c.solver.step > 0 ? 0.0 : c.solver.rtol);
  s.tables->set_attribute("summary", to_json(summary).dump());
  // Its final state kept, a finished run can be continued to a later t_end:
  // the checkpoint at t_end, written before summary.json, so a stop between
  // the two leaves a run a restart finishes. Otherwise it has nothing left to
  // resume.
  if (c.output.final_state)
    s.checkpoint(t_end, s.rows);
  else
    std::filesystem::remove(s.options.out_dir / kCheckpointFile);
  write_summary(s.options.out_dir, summary);
  return summary;
}

Summary run_case(const Case& c, const RunOptions& options) {
  CaseRun case_run(c, options);
  while (case_run.next_output() <= case_run.outputs()) case_run.output();
  return case_run.finish();
}

}  // namespace stickslip
