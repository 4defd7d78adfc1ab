#include "stickslip/integrate/stepping_integrator.hpp"

#include <algorithm>
#include <functional>
#include <limits>
#include <utility>

#include "failure.hpp"
#include "stickslip/integrate/serial_vector_kernels.hpp"

namespace stickslip {

SteppingIntegrator::SteppingIntegrator(const PackageCalls& calls, const System& system,
                                       const SolverParams& solver, std::span<const double> y0,
                                       IntegratorOptions options, double t0, double t_stop)
    : solver_(solver),
      method_(method_info(solver.method)),
      stages_(stage_solve(solver.method, solver.linear_solver)),
      y_(make_serial_vector(y0, ctx_)),
      calls_(calls),
      system_(system),
      options_(std::move(options)),
      roots_(options_.watched_contacts.size(), 0),
      peaks_(options_.watched_contacts.size()),
      poll_steps_(poll_steps(solver.method, solver.linear_solver)),
      t_stop_(t_stop),
      t_last_step_(t0),
      pending_y_(N_VClone(y_.get())),
      mem_(nullptr, PackageFree{calls.free}) {
  if (options_.on_step) {
    scratch_error_.reset(N_VClone(y_.get()));
    scratch_weights_.reset(N_VClone(y_.get()));
  }
}

void SteppingIntegrator::adopt_package(void* mem, const char* create_call) {
  check_created(mem, create_call);
  mem_.reset(mem);
  check_call(calls_.set_err_handler_fn(mem, record_solver_message, &message_), "SetErrHandlerFn");
}

void SteppingIntegrator::set_up_package() {
  check_call(calls_.set_user_data(mem(), static_cast<SteppingIntegrator*>(this)), "SetUserData");
  atol_ = make_serial_vector(absolute_tolerances(system_, solver_), ctx_);
  check_call(calls_.sv_tolerances(mem(), solver_.rtol, atol_.get()), "SVtolerances");
  check_call(calls_.set_stop_time(mem(), t_stop_), "SetStopTime");
  if (!roots_.empty())
    check_call(calls_.root_init(mem(), static_cast<int>(roots_.size()), root_fn), "RootInit");
}

int SteppingIntegrator::full_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<SteppingIntegrator*>(self);
  return guarded(me->pending_, [&] {
    me->system_.rhs(t, as_span(y), as_span(ydot), loop_threads(me->options_));
  });
}

int SteppingIntegrator::explicit_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<SteppingIntegrator*>(self);
  return guarded(me->pending_, [&] {
    me->system_.rhs_explicit(t, as_span(y), as_span(ydot), loop_threads(me->options_));
  });
}

int SteppingIntegrator::implicit_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<SteppingIntegrator*>(self);
  return guarded(me->pending_, [&] { me->system_.rhs_implicit(t, as_span(y), as_span(ydot)); });
}

// The packages evaluate the root functions at every accepted step's end (or
// an output time inside the step) and where they locate a crossing: each
// evaluation is also a sample of the contacts' speeds for peak_speeds.
int SteppingIntegrator::root_fn(double t, N_Vector y, double* g, void* self) {
  auto* me = static_cast<SteppingIntegrator*>(self);
  return guarded(me->pending_, [&] {
    const auto state = as_span(y);
    const auto& watched = me->options_.watched_contacts;
    me->system_.contact_set().stick_slip_roots(state, watched,
                                               std::span<double>(g, me->roots_.size()));
    for (std::size_t k = 0; k < watched.size(); ++k)
      me->peaks_.sample_frontier(
          k, t,
          me->system_.contact_set().contact_speed(static_cast<std::size_t>(watched[k]), state));
  });
}

void SteppingIntegrator::solve_per_contact() {
  const System& system = system_;
  stage_solver_ = make_exact_stage_solver(
      ctx_, calls_.stage_package,
      [&system](double, double gamma, std::span<const double> predictor, std::span<const double>,
                std::span<double> z) {
        return system.contact_set().solve_implicit_stage(gamma, predictor, z);
      },
      stage_stats_, pending_);
  check_call(calls_.set_nonlinear_solver(mem(), stage_solver_.get()), "SetNonlinearSolver");
}

void SteppingIntegrator::solve_lattice() {
  // Steps grow to ~1e-4 s while the contacts creep; where a slip starts
  // they must shrink by 1e5 within one step, more than the default 7
  // error-test failures (each cuts h by at most 10×) allow.
  check_call(calls_.set_max_err_test_fails(mem(), kMaxErrorTestFailures), "SetMaxErrTestFails");
  check_call(calls_.set_max_conv_fails(mem(), kMaxStageFailures), "SetMaxConvFails");
  lattice_stages_ = std::make_unique<LatticeStageSolver>(
      system_, LatticeStageSolver::kMaxGammaLambda, LatticeStageSolver::ContactNewton::by_count,
      options_.threads);
  stage_solver_ = make_exact_stage_solver(
      ctx_, calls_.stage_package,
      std::bind_front(&LatticeStageSolver::solve, lattice_stages_.get()), stage_stats_, pending_);
  check_call(calls_.set_nonlinear_solver(mem(), stage_solver_.get()), "SetNonlinearSolver");
}

double SteppingIntegrator::current_time() const {
  double t = 0.0;
  calls_.get_current_time(mem(), &t);
  return t;
}

long SteppingIntegrator::steps_taken() const {
  long n = 0;
  calls_.get_num_steps(mem(), &n);
  return n;
}

double SteppingIntegrator::last_step_size() const {
  double h = 0.0;
  calls_.get_last_step(mem(), &h);
  return h;
}

int SteppingIntegrator::evolve(double t_out, double* t, bool one_step) {
  const int flag = calls_.evolve(mem(), t_out, y_.get(), t,
                                 one_step ? calls_.one_step_task : calls_.normal_task);
  rethrow_pending();
  return flag;
}

void SteppingIntegrator::root_info(int* roots) {
  check_call(calls_.get_root_info(mem(), roots), "GetRootInfo");
}

void SteppingIntegrator::interpolate(double t, N_Vector y) {
  check_call(calls_.get_dky(mem(), t, 0, y), "GetDky");
}

bool SteppingIntegrator::local_errors(N_Vector error, N_Vector weights) const {
  return calls_.get_est_local_errors(mem(), error) >= 0 &&
         calls_.get_err_weights(mem(), weights) >= 0;
}

std::string SteppingIntegrator::flag_name(int flag) const {
  return stickslip::flag_name(calls_.get_return_flag_name, flag);
}

double SteppingIntegrator::local_error_norm() {
  if (!method_.error_estimate || !local_errors(scratch_error_.get(), scratch_weights_.get())) {
    message_.take();  // no estimate is no failure
    return std::numeric_limits<double>::quiet_NaN();
  }
  return N_VWrmsNorm(scratch_error_.get(), scratch_weights_.get());
}

void SteppingIntegrator::throw_failure(int flag, double t) {
  const std::string said = message_.take();  // before local_errors may report
  NVectorPtr err(N_VClone(y_.get())), weights(N_VClone(y_.get()));
  const bool have = local_errors(err.get(), weights.get());
  message_.take();
  throw IntegrationError(describe_failure(system_, calls_.evolve_name, flag_name(flag), said, t,
                                          err.get(), weights.get(), have));
}

void SteppingIntegrator::check(int flag, const char* call) {
  if (flag >= 0) return;
  std::string what = std::string(call) + " failed: " + flag_name(flag);
  if (const std::string said = message_.take(); !said.empty()) what += ": " + said;
  throw IntegrationError(what);
}

void SteppingIntegrator::check_call(int flag, const char* call_suffix) {
  if (flag >= 0) return;
  check(flag, (std::string(calls_.prefix) + call_suffix).c_str());
}

void SteppingIntegrator::add_stage_stats(SolverStats& s) const {
  if (stages_ == StageSolve::per_contact || stages_ == StageSolve::exact_lattice)
    s.newton_iterations = stage_stats_.iterations;
  if (lattice_stages_) {
    s.linear_setups = lattice_stages_->lattice().factorizations();
    s.jacobian_evaluations = lattice_stages_->contact_factorizations();
    s.krylov_iterations = lattice_stages_->krylov_iterations();
  }
}

void SteppingIntegrator::rethrow_pending() {
  if (!pending_) return;
  message_.take();  // SUNDIALS' word on the callback's failure: the exception says more
  std::rethrow_exception(std::exchange(pending_, nullptr));
}

double SteppingIntegrator::advance(double t_out, std::span<double> y) {
  const ScopedKernelThreads kernels(loop_threads(options_));
  std::fill(roots_.begin(), roots_.end(), 0);
  // Stepwise until the first step is taken (its h0 then comes from t_stop,
  // not t_out) and while a root found beyond an output time waits.
  const bool stepwise = options_.on_step || pending_root_ || steps_taken() == 0;
  const double t = stepwise ? advance_stepwise(t_out, y) : advance_normal(t_out, y);
  peaks_.close(t);
  return t;
}

double SteppingIntegrator::finish(double t, std::span<double> y) {
  const auto values = as_span(y_.get());
  std::copy(values.begin(), values.end(), y.begin());
  return t;
}

void SteppingIntegrator::throw_if_out_of_steps() {
  const long taken = steps_taken();
  if (taken >= solver_.max_steps)
    throw IntegrationError(describe_out_of_steps(current_time(), taken, last_step_size()));
}

double SteppingIntegrator::advance_normal(double t_out, std::span<double> y) {
  double t = 0.0;
  int flag = kSuccess;
  for (;;) {
    throw_if_out_of_steps();
    check_call(
        calls_.set_max_num_steps(mem(), std::min(poll_steps_, solver_.max_steps - steps_taken())),
        "SetMaxNumSteps");
    flag = evolve(t_out, &t, false);
    if (flag != kTooMuchWork) break;
    if (options_.poll && options_.poll()) return finish(t, y);  // y_: the state at t, a step's end
  }
  if (flag < 0) throw_failure(flag, t);
  if (flag == kRoot) {
    root_info(roots_.data());
    return finish(t, y);
  }
  return finish(t_out, y);
}

// A post-step hook (ARKStepSetPostprocessStepFn) would be simpler, but with it
// ARKStep re-evaluates the right-hand side at every step's end, which changes
// the dense output: ~1160 spurious stick/slip events in 0.3 ms on a 10×10×4
// lattice where there are none. CVODE has no such hook at all.
double SteppingIntegrator::advance_stepwise(double t_out, std::span<double> y) {
  if (pending_root_) {
    if (pending_t_ <= t_out) {
      pending_root_ = false;
      roots_ = pending_roots_;
      N_VScale(1.0, pending_y_.get(), y_.get());
      return finish(pending_t_, y);
    }
    interpolate(t_out, y_.get());
    return finish(t_out, y);
  }
  long polled_at = steps_taken();
  for (;;) {
    double t = 0.0;
    const double t_now = current_time();
    if (t_now >= t_out) {
      // t_out lies in the last step: its roots up to t_out, then the
      // interpolated state, as normal mode gives them; no new step.
      const int flag = evolve(t_out, &t, false);
      if (flag < 0) throw_failure(flag, t);
      if (flag != kRoot) return finish(t_out, y);
      root_info(roots_.data());
      return finish(t, y);
    }
    throw_if_out_of_steps();
    // In ONE_STEP mode the target only sets the first step's size.
    const int flag = evolve(t_stop_, &t, true);
    if (flag < 0) throw_failure(flag, t);
    record_step();
    if (flag != kRoot) {
      // Every poll_steps steps, as normal mode: y_ is this step's end, t.
      if (t < t_out && steps_taken() - polled_at >= poll_steps_) {
        polled_at = steps_taken();
        if (options_.poll && options_.poll()) return finish(t, y);
      }
      continue;
    }
    root_info(roots_.data());
    if (t <= t_out) return finish(t, y);
    // The root lies beyond t_out: report t_out first (it is inside this step).
    pending_root_ = true;
    pending_t_ = t;
    pending_roots_ = roots_;
    N_VScale(1.0, y_.get(), pending_y_.get());
    std::fill(roots_.begin(), roots_.end(), 0);
    interpolate(t_out, y_.get());
    return finish(t_out, y);
  }
}

void SteppingIntegrator::record_step() {
  if (!options_.on_step) return;
  const double t = current_time();
  // After a root or an output inside a step, ONE_STEP mode first hands back
  // that same step: not a new one.
  if (t <= t_last_step_) return;
  const double h = t - t_last_step_;
  // y_ holds the step's end (ONE_STEP mode).
  const StepRecord r{t, h, local_error_norm(),
                     h * system_.contact_set().weakening_rate(as_span(y_.get()))};
  t_last_step_ = t;
  options_.on_step(r);
}

}  // namespace stickslip
