#pragma once
// What the ARKStep and CVODE adapters share: how advance() drives a SUNDIALS
// integrator. In normal mode it returns every poll interval of steps (the
// "too much work" return) to ask poll() and to hold max_steps over the whole
// run; with steps recorded it takes one step per call (ONE_STEP mode) and
// interpolates outputs exactly as normal mode does, so recording steps never
// changes a run. ARKStep and CVODE give the calls made here the same
// signatures, their return flags the same values (each adapter asserts it)
// and their callbacks the same signatures, so each adapter hands this driver
// a table of its package's calls (PackageCalls) and the package's memory it
// made (adopt_package), which the table's `free` releases; the callbacks, the
// set-up both share, the stage solvers (SUNDIALS nonlinear solvers that solve
// each implicit stage exactly: contact by contact for imex, the lattice by FFT
// and the contacts by Newton for dirk and bdf; no SUNDIALS linear solver) and
// what is read off the error estimate live here, once.
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

// The calls of one SUNDIALS package that the driver makes (ARKStep's or
// CVODE's), and the prefix of their names for messages ("ARKStep" makes
// "ARKStepSetUserData").
struct PackageCalls {
  const char* prefix;
  const char* evolve_name;  // ARKStepEvolve, CVode
  StagePackage stage_package;
  int (*evolve)(void* mem, double t_out, N_Vector y, double* t, int task);
  int one_step_task, normal_task;
  int (*get_current_time)(void* mem, double* t);
  int (*get_num_steps)(void* mem, long* steps);
  int (*get_last_step)(void* mem, double* h);
  int (*set_max_num_steps)(void* mem, long steps);
  int (*get_root_info)(void* mem, int* roots);
  int (*get_dky)(void* mem, double t, int derivative, N_Vector dky);
  int (*get_est_local_errors)(void* mem, N_Vector error);
  int (*get_err_weights)(void* mem, N_Vector weights);
  char* (*get_return_flag_name)(long flag);
  int (*set_err_handler_fn)(void* mem, void (*handler)(int, const char*, const char*, char*, void*),
                            void* data);
  int (*set_user_data)(void* mem, void* data);
  int (*sv_tolerances)(void* mem, double rtol, N_Vector atol);
  int (*set_stop_time)(void* mem, double t_stop);
  int (*root_init)(void* mem, int roots, int (*g)(double, N_Vector, double*, void*));
  int (*set_max_err_test_fails)(void* mem, int fails);
  int (*set_max_conv_fails)(void* mem, int fails);
  int (*set_nonlinear_solver)(void* mem, SUNNonlinearSolver solver);
  void (*free)(void** mem);
};

class SteppingIntegrator : public Integrator {
 public:
  double advance(double t_out, std::span<double> y) final;
  std::span<const int> roots() const final { return roots_; }
  std::span<const double> peak_speeds() const final { return peaks_.peaks(); }

  // The return flags of ARKStepEvolve and CVode (equal in both packages: the
  // adapters assert it).
  static constexpr int kSuccess = 0, kStopTime = 1, kRoot = 2, kTooMuchWork = -1;

 protected:
  // What an adapter uses: it makes the package's memory from y_ in ctx_,
  // hands it over (adopt_package), initializes it as its package needs, then
  // sets what both packages set alike and what is its own.

  // Makes y_ (from y0) and everything sized by it or by the watched contacts.
  SteppingIntegrator(const PackageCalls& calls, const System& system, const SolverParams& solver,
                     std::span<const double> y0, IntegratorOptions options, double t0,
                     double t_stop);

  // The package's memory: owned from here on, its error handler set first,
  // so that every later call's message reaches its exception.
  void adopt_package(void* mem, const char* create_call);
  // What both packages set alike, after the package's own initialization:
  // the user data, the tolerances, the stop time and the root functions.
  void set_up_package();
  // The implicit part solved exactly, the solver attached to the package:
  // contact by contact (imex), or the whole lattice (dirk, bdf), which also
  // allows a slip's onset the step cuts it needs.
  void solve_per_contact();
  void solve_lattice();
  void* mem() const { return mem_.get(); }

  // The right-hand sides of both packages (user data: this, as a
  // SteppingIntegrator*).
  static int full_rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int explicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);  // imex's lattice
  static int implicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);  // imex's contacts
  // check() for the calls on this integrator's package: the IntegrationError
  // names the call, the flag and the message SUNDIALS reported.
  void check(int flag, const char* call);
  // The stage solver's part of the statistics (exact stage solves only).
  void add_stage_stats(SolverStats& s) const;

  SolverParams solver_;
  const MethodInfo& method_;
  const StageSolve stages_;  // how the implicit part is solved
  // Declared before every SUNDIALS object (the package's memory is the last
  // member, so freed first), so the context goes after everything made in it.
  SunContext ctx_;
  NVectorPtr y_;  // the state handed to and from the package

 private:
  struct PackageFree {
    void (*free)(void**);
    void operator()(void* mem) const { free(&mem); }
  };

  static int root_fn(double t, N_Vector y, double* g, void* self);
  // check() for a call named by its suffix after the package's prefix
  // ("SetUserData").
  void check_call(int flag, const char* call_suffix);
  // Rethrows an exception a callback stored (after each package call).
  void rethrow_pending();

  double current_time() const;  // end of the last step
  long steps_taken() const;
  double last_step_size() const;
  // One call of the package's evolve (ONE_STEP or NORMAL mode) into y_;
  // rethrows an exception a callback raised.
  int evolve(double t_out, double* t, bool one_step);
  void root_info(int* roots);
  void interpolate(double t, N_Vector y);  // the dense output at t
  // The last step's local error estimate and its error weights; false if the
  // package has none now.
  bool local_errors(N_Vector error, N_Vector weights) const;
  std::string flag_name(int flag) const;
  // Weighted RMS norm of the last step's local error estimate; NaN if none.
  double local_error_norm();
  [[noreturn]] void throw_failure(int flag, double t);

  double advance_normal(double t_out, std::span<double> y);
  double advance_stepwise(double t_out, std::span<double> y);
  double finish(double t, std::span<double> y);
  void throw_if_out_of_steps();
  void record_step();

  const PackageCalls& calls_;
  const System& system_;
  IntegratorOptions options_;
  NVectorPtr atol_;
  std::vector<int> roots_;
  SpeedPeaks peaks_;  // sampled in root_fn
  StageStats stage_stats_;
  std::unique_ptr<LatticeStageSolver> lattice_stages_;
  NonlinearSolverPtr stage_solver_;
  std::exception_ptr pending_;
  SolverMessage message_;  // the error handler's user data (record_solver_message)
  const long poll_steps_;  // steps between polls (case/methods.hpp)
  NVectorPtr scratch_error_, scratch_weights_;
  double t_stop_;       // the stop time: what ONE_STEP calls aim at
  double t_last_step_;  // end of the last step written to steps.csv
  // A root found beyond the output time by the step that crossed it.
  bool pending_root_ = false;
  double pending_t_ = 0.0;
  std::vector<int> pending_roots_;
  NVectorPtr pending_y_;
  // Last, so freed first: it refers to the vectors, the solvers and the
  // message above.
  std::unique_ptr<void, PackageFree> mem_;
};

}  // namespace stickslip
