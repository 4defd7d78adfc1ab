#pragma once
// The integrators a case can choose ([solver] method), behind one interface
// (make_integrator.hpp makes them). The adapters own the SUNDIALS handles (the package's in each
// adapter, the stage and linear solvers in SteppingIntegrator, which they share); the physics is
// the System's. What each method is, and how its implicit part is solved, is its row in
// case/methods.hpp.

#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/case/methods.hpp"
#include "stickslip/integrate/solver_stats.hpp"
#include "stickslip/integrate/step_record.hpp"
#include "stickslip/integrate/tolerances.hpp"
#include "stickslip/model/parallel_for.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

struct IntegratorOptions {
  std::vector<int> watched_contacts;               // stick/slip root functions, none if empty
  std::function<void(const StepRecord&)> on_step;  // called after every accepted step, if set
  // Called after every attempt at a step, if set, by the steppers whose
  // attempts are this project's own (multirate); SUNDIALS' packages report
  // accepted steps only.
  std::function<void(const AttemptRecord&)> on_attempt;
  // Called every poll interval of steps inside advance() (a few hundred: the
  // linear solver's row, case/methods.cpp); when it returns true,
  // advance() returns at the end of the last accepted step. This is how a
  // run stalled inside one output interval still answers SIGINT/SIGTERM and
  // flushes its outputs.
  std::function<bool()> poll;
  // The run's threads, which the integrator's loops use as many of as it
  // says now (the run lowers it while they wait for cores). Unset:
  // make_integrator gives [solver] threads, resolved; an integrator made
  // without one runs on one thread.
  std::shared_ptr<const ThreadBudget> threads;
};

// The threads an integrator's loops use now under `options`.
inline int loop_threads(const IntegratorOptions& options) {
  return options.threads ? options.threads->now() : 1;
}

// Error-test failures allowed in one step of an exactly solved implicit method
// (SUNDIALS' default: 7).
inline constexpr int kMaxErrorTestFailures = 20;
// Refused stage solves allowed in one step, likewise (SUNDIALS' default: 10,
// each cutting h by 4): a stage that leaves a contact slipping faster than
// the step resolves is refused (LatticeStageSolver), and from a creep step of
// 5e-4 s the step may have to fall to 1e-10 s at a slip's onset.
inline constexpr int kMaxStageFailures = 20;

class Integrator {
 public:
  virtual ~Integrator() = default;
  // Integrates toward t_out and returns the time reached: t_out, or earlier
  // when a watched contact starts or stops slipping (then roots() says which),
  // or when poll() asked to stop (then every root is 0). y receives the state
  // at the returned time; output times are interpolated, not stepped to, and
  // do not change the steps (stepping_integrator.hpp). More than [solver]
  // max_steps steps in all (counted from this integrator's start) throw
  // IntegrationError.
  virtual double advance(double t_out, std::span<double> y) = 0;
  // After advance returned early: per watched contact +1 (slip), −1 (stick), 0.
  virtual std::span<const int> roots() const = 0;
  // Per watched contact, the largest speed |s| [m/s] at which the integrator
  // sampled its solution between the previous return of advance and this one
  // (both included); −∞ where it sampled none. The samples are those it takes
  // anyway (integrate/speed_peaks.hpp): the root functions' evaluations, at
  // every accepted step's end and where a crossing is located, and with
  // multirate a fast contact's every sub-step end. On the solution, so never
  // above its true maximum; below it by at most what the solution curves
  // between samples. Empty without watched contacts.
  virtual std::span<const double> peak_speeds() const = 0;
  virtual SolverStats stats() const = 0;
  // What only the integrator knows of how the result was obtained: its
  // method, the package's integrator and its order and stages (or BDF's
  // largest order). describe_solver (make_integrator.hpp) adds the rest of
  // summary.json's `solver` object.
  virtual nlohmann::json description() const = 0;
};

}  // namespace stickslip
