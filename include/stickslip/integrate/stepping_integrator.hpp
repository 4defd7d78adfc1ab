#pragma once
// What the ARKStep and CVODE adapters share: how advance() drives a SUNDIALS
// integrator. In normal mode it returns every poll interval of steps (the
// "too much work" return) to ask poll() and to hold max_steps over the whole
// run; with steps recorded it takes one step per call (ONE_STEP mode) and
// interpolates outputs exactly as normal mode does, so recording steps never
// changes a run. Each adapter supplies the package's calls; ARKStep and
// CVODE give their return flags the same values, and their callbacks the
// same signatures: the callbacks, the stage and linear solvers and what is
// read off the package's error estimate live here, once for both.
//
// Output times must not change the solution either. Both packages choose
// their first step from the first time asked for (h0 ≤ 0.1 (t_out − t0)), so
// the first output interval set h0 and the whole step sequence after it
// (Fig. 10b's pair: 7 841 steps at an interval of 1e-6 s, 7 790 at 1e-5 s).
// The first advance() therefore steps one step at a time (ONE_STEP mode)
// toward the stop time, as a recorded run does, so h0 comes from t_stop.

#include <exception>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "stickslip/integrate/exact_stage_solver.hpp"
#include "stickslip/integrate/integrator.hpp"
#include "stickslip/integrate/lattice_stage_solver.hpp"
#include "stickslip/integrate/speed_peaks.hpp"
#include "stickslip/integrate/sundials.hpp"

namespace stickslip {

class SteppingIntegrator : public Integrator {
 public:
  double advance(double t_out, std::span<double> y) final;
  std::span<const int> roots() const final { return roots_; }
  std::span<const double> peak_speeds() const final { return peaks_.peaks(); }

 protected:
  // The return flags of ARKStepEvolve and CVode (equal in both packages).
  static constexpr int kSuccess = 0, kStopTime = 1, kRoot = 2, kTooMuchWork = -1;

  SteppingIntegrator(const System& system, const SolverParams& solver, IntegratorOptions options,
                     double t0, double t_stop);

  virtual double current_time() const = 0;  // end of the last step
  virtual long steps_taken() const = 0;
  virtual double last_step_size() const = 0;
  virtual void set_max_steps(long steps) = 0;
  // One call of the package's evolve (ONE_STEP or NORMAL mode) into y_;
  // rethrows an exception a callback raised.
  virtual int evolve(double t_out, double* t, bool one_step) = 0;
  virtual void root_info(int* roots) = 0;
  virtual void interpolate(double t, N_Vector y) = 0;  // the dense output at t
  // The last step's local error estimate and its error weights; false if the
  // package has none now.
  virtual bool local_errors(N_Vector error, N_Vector weights) const = 0;
  // The package's name of its evolve call and of a return flag, for messages.
  virtual const char* evolve_name() const = 0;
  virtual std::string flag_name(int flag) const = 0;

  // Call once y_ exists (it sizes the scratch vectors).
  void init_stepping(std::size_t watched_contacts);

  // The callbacks of both packages (user data: this, as a SteppingIntegrator*).
  static int full_rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int explicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);  // imex's lattice
  static int implicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);  // imex's contacts
  static int root_fn(double t, N_Vector y, double* g, void* self);
  void* user_data() { return static_cast<SteppingIntegrator*>(this); }

  // The solvers of the implicit part (StageSolve): made here, attached to the
  // package by the adapter.
  void make_per_contact_stages(StagePackage package);
  void make_lattice_stages(StagePackage package);
  // Weighted RMS norm of the last step's local error estimate; NaN if none.
  double local_error_norm();
  [[noreturn]] void throw_failure(int flag, double t);
  // check() for the calls on this integrator's package: the IntegrationError
  // names the call, the flag and the message SUNDIALS reported.
  void check(int flag, const char* call);
  // The stage solver's part of the statistics (exact stage solves only).
  void add_stage_stats(SolverStats& s) const;
  // Rethrows an exception a callback stored (after each package call).
  void rethrow_pending();

  const System& system_;
  SolverParams solver_;
  const MethodInfo& method_;
  const StageSolve stages_;  // how the implicit part is solved
  IntegratorOptions options_;
  // Declared before every SUNDIALS object of the hierarchy (these below and
  // the adapters' memory, destroyed with the derived class, before this
  // base's members), so the context goes after everything made in it.
  SunContext ctx_;
  NVectorPtr y_;  // the state handed to and from the package
  NVectorPtr atol_;
  std::vector<int> roots_;
  SpeedPeaks peaks_;  // sampled in root_fn
  StageStats stage_stats_;
  std::unique_ptr<LatticeStageSolver> lattice_stages_;
  NonlinearSolverPtr stage_solver_;
  std::exception_ptr pending_;
  SolverMessage message_;  // the error handler's user data (record_solver_message)

 private:
  double advance_normal(double t_out, std::span<double> y);
  double advance_stepwise(double t_out, std::span<double> y);
  double finish(double t, std::span<double> y);
  void throw_if_out_of_steps();
  void record_step();

  const long poll_steps_;  // steps between polls (case/methods.hpp)
  NVectorPtr scratch_error_, scratch_weights_;
  double t_stop_;       // the stop time: what ONE_STEP calls aim at
  double t_last_step_;  // end of the last step written to steps.csv
  // A root found beyond the output time by the step that crossed it.
  bool pending_root_ = false;
  double pending_t_ = 0.0;
  std::vector<int> pending_roots_;
  NVectorPtr pending_y_;
};

}  // namespace stickslip
