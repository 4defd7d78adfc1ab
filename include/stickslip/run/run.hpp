#pragma once
// One run of a case: builds the System, integrates it, and streams the
// observables to the output directory (the Monitor of STYLE.md).

#include <filesystem>
#include <functional>
#include <memory>
#include <span>

#include "stickslip/case/case.hpp"
#include "stickslip/integrate/integrator.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/writers.hpp"

namespace stickslip {

struct RunOptions {
  std::filesystem::path out_dir;
  bool overwrite = false;
  bool quiet = false;  // no progress on stderr
  // Continue the run in out_dir from its checkpoint (a finished run too, to
  // the case's later run.t_end, when it kept its final state).
  bool restart = false;
  // Continue a checkpoint written by another code version (summary.json then
  // lists each attempt's version): for changes that leave the numbers alone.
  bool any_version = false;
  // Called with the simulated time and the steps so far at the first output
  // time, then twice a second at most, whether or not stderr is a terminal
  // (the Python module's progress bar in a notebook).
  std::function<void(double t, long steps)> on_progress{};
  // Asked between output times (every poll interval of steps) and at each:
  // the signal that asks the run to stop, 0 while none has. A stopped run
  // checkpoints and throws Interrupted. Unset: SIGINT or SIGTERM, as caught
  // by the handlers below.
  std::function<int()> stop_signal{};
};

// Thrown when SIGINT or SIGTERM stopped a run, after its final checkpoint was
// written and every output flushed.
struct Interrupted {
  int signal = 0;
  double t = 0.0;
};

// SIGINT and SIGTERM then stop a run, instead of killing it, at its next
// output time or sooner: the integrators poll between output times every
// poll interval of steps (a few hundred: case/methods.cpp), and a stop there
// ends the run at that step's end.
void install_stop_handlers();

// The same for the span of one run in a program that has handlers of its own
// (the Python module), whose runs may go on in several threads at once. While
// any of these lives, SIGINT and SIGTERM stop every run in the process; the
// first to be made clears an earlier stop request and replaces the handlers,
// the last to go puts them back.
class ScopedStopHandlers {
 public:
  ScopedStopHandlers();
  ~ScopedStopHandlers();
  ScopedStopHandlers(const ScopedStopHandlers&) = delete;
  ScopedStopHandlers& operator=(const ScopedStopHandlers&) = delete;
};

// The output directory of a case: --out if given, else [output] dir, else
// out/<case file stem> in the working directory.
std::filesystem::path output_dir_for(const Case& c, const std::filesystem::path& out_flag);

// Runs the case and returns what it wrote to summary.json (IntegrationError
// if the integration or its energy audit fails, OutputError for an unusable
// output directory or a refused restart, ResumableRunError (run/resume.hpp)
// for a fresh start where a restart is wanted, LiveRunError (run/run_lock.hpp)
// while another run writes to the directory, Interrupted on SIGINT/SIGTERM).
// It is a CaseRun driven output time by output time, then finished.
Summary run_case(const Case& c, const RunOptions& options);

// One run in its phases, for run_case and for tests that look inside it.
//  - made: the output directory locked for the run's lifetime
//    (run/run_lock.hpp) and checked (or, on a restart, the checkpoint read
//    and checked: run/resume.hpp), the System, the recorders and the
//    integrator set up, and the first row recorded;
//  - output(): integrates to the next output time (recording the stick/slip
//    events on the way, stopping at t_avg for μ's impulse), records that row,
//    and checkpoints or stops as the case and the signals ask;
//  - finish(): after the last output, the energy audit, every recorder's
//    part, summary.json.
// An exception from any phase leaves the rows written so far flushed.
class CaseRun {
 public:
  CaseRun(const Case& c, const RunOptions& options);
  ~CaseRun();
  CaseRun(const CaseRun&) = delete;
  CaseRun& operator=(const CaseRun&) = delete;

  long next_output() const;  // the row output() records next: 1, 2, ..., outputs()
  long outputs() const;      // rows after t = 0: ceil(t_end / interval)
  void output();
  Summary finish();
  std::span<const double> state() const;  // at the last output time
  const System& system() const;

 private:
  struct State;
  std::unique_ptr<State> s_;
};

}  // namespace stickslip
