#pragma once
// What the ARKStep and CVODE adapters share: how advance() drives a SUNDIALS
// integrator. In normal mode it returns every kPollSteps steps (the
// "too much work" return) to ask poll() and to hold max_steps over the whole
// run; with steps recorded it takes one step per call (ONE_STEP mode) and
// interpolates outputs exactly as normal mode does, so recording steps never
// changes a run. Each adapter supplies the package's calls; ARKStep and
// CVODE give their return flags the same values.
//
// Output times must not change the solution either. Both packages choose
// their first step from the first time asked for (h0 ≤ 0.1 (t_out − t0)), so
// the first output interval set h0 and the whole step sequence after it
// (Fig. 10b's pair: 7 841 steps at an interval of 1e-6 s, 7 790 at 1e-5 s).
// The first advance() therefore steps one step at a time (ONE_STEP mode)
// toward the stop time, as a recorded run does, so h0 comes from t_stop.

#include <span>
#include <vector>

#include "stickslip/integrate/integrator.hpp"
#include "stickslip/integrate/sundials.hpp"

namespace stickslip {

class SteppingIntegrator : public Integrator {
 public:
  double advance(double t_out, std::span<double> y) final;
  std::span<const int> roots() const final { return roots_; }

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
  // Weighted RMS norm of the last step's local error estimate; NaN if none.
  virtual double local_error_norm() = 0;
  [[noreturn]] virtual void throw_failure(int flag, double t) = 0;

  // Call once y_ exists (it sizes the scratch vectors).
  void init_stepping(std::size_t watched_contacts);

  const System& system_;
  SolverParams solver_;
  IntegratorOptions options_;
  SunContext ctx_;  // first member of the adapters' hierarchy: destroyed last
  NVectorPtr y_;    // the state handed to and from the package
  std::vector<int> roots_;

 private:
  double advance_normal(double t_out, std::span<double> y);
  double advance_stepwise(double t_out, std::span<double> y);
  double finish(double t, std::span<double> y);
  void throw_if_out_of_steps();
  void record_step();

  double t_stop_;       // the stop time: what ONE_STEP calls aim at
  double t_last_step_;  // end of the last step written to steps.csv
  // A root found beyond the output time by the step that crossed it.
  bool pending_root_ = false;
  double pending_t_ = 0.0;
  std::vector<int> pending_roots_;
  NVectorPtr pending_y_;
};

}  // namespace stickslip
