#include "stickslip/integrate/cvode_integrator.hpp"

#include <cvode/cvode.h>
#include <sunlinsol/sunlinsol_klu.h>

#include <algorithm>
#include <limits>
#include <utility>

#include "failure.hpp"

namespace stickslip {

CvodeIntegrator::CvodeIntegrator(const System& system, const SolverParams& solver,
                                 std::span<const double> y0, double t0, double t_stop,
                                 IntegratorOptions options)
    : system_(system),
      solver_(solver),
      options_(std::move(options)),
      t_last_step_(t0),
      // BDF of order ≥ 3 is not A-stable and the lattice modes are lightly
      // damped: at loose tolerance it produced spurious slips (MODEL.md §12).
      max_order_(solver.order > 0 ? solver.order : 2) {
  y_ = make_serial_vector(y0, ctx_);
  cvode_mem_ = CVodeCreate(CV_BDF, ctx_);
  check_created(cvode_mem_, "CVodeCreate");
  check(CVodeInit(cvode_mem_, rhs, t0, y_.get()), "CVodeInit");
  check(CVodeSetUserData(cvode_mem_, this), "CVodeSetUserData");
  atol_ = make_serial_vector(absolute_tolerances(system, solver), ctx_);
  check(CVodeSVtolerances(cvode_mem_, solver.rtol, atol_.get()), "CVodeSVtolerances");
  check(CVodeSetStopTime(cvode_mem_, t_stop), "CVodeSetStopTime");
  check(CVodeSetErrHandlerFn(cvode_mem_, print_solver_message, nullptr), "CVodeSetErrHandlerFn");
  check(CVodeSetMaxOrd(cvode_mem_, max_order_), "CVodeSetMaxOrd");
  if (max_order_ >= 3) check(CVodeSetStabLimDet(cvode_mem_, SUNTRUE), "CVodeSetStabLimDet");

  jacobian_ = system.jacobian_pattern(JacobianPart::full);
  matrix_ = make_sparse_matrix(jacobian_, ctx_);
  linear_solver_.reset(SUNLinSol_KLU(y_.get(), matrix_.get(), ctx_));
  check_created(linear_solver_.get(), "SUNLinSol_KLU");
  check(CVodeSetLinearSolver(cvode_mem_, linear_solver_.get(), matrix_.get()),
        "CVodeSetLinearSolver");
  check(CVodeSetJacFn(cvode_mem_, jacobian), "CVodeSetJacFn");

  roots_.assign(options_.watched_contacts.size(), 0);
  if (!roots_.empty())
    check(CVodeRootInit(cvode_mem_, static_cast<int>(roots_.size()), root_fn), "CVodeRootInit");
  if (options_.on_step) {
    scratch_error_.reset(N_VClone(y_.get()));
    scratch_weights_.reset(N_VClone(y_.get()));
    pending_y_.reset(N_VClone(y_.get()));
  }
}

CvodeIntegrator::~CvodeIntegrator() {
  CVodeFree(&cvode_mem_);
}

int CvodeIntegrator::rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<CvodeIntegrator*>(self);
  return guarded(me->pending_, [&] { me->system_.rhs(t, as_span(y), as_span(ydot)); });
}

int CvodeIntegrator::root_fn(double, N_Vector y, double* g, void* self) {
  auto* me = static_cast<CvodeIntegrator*>(self);
  return guarded(me->pending_, [&] {
    me->system_.stick_slip_roots(as_span(y), me->options_.watched_contacts,
                                 std::span<double>(g, me->roots_.size()));
  });
}

int CvodeIntegrator::jacobian(double, N_Vector y, N_Vector, SUNMatrix J, void* self, N_Vector,
                              N_Vector, N_Vector) {
  auto* me = static_cast<CvodeIntegrator*>(self);
  return guarded(me->pending_, [&] {
    me->system_.jacobian_values(as_span(y), me->jacobian_);
    copy_into(me->jacobian_, J);
  });
}

void CvodeIntegrator::record_step() {
  StepRecord r{0.0, 0.0, std::numeric_limits<double>::quiet_NaN()};
  CVodeGetCurrentTime(cvode_mem_, &r.t);
  // In CV_ONE_STEP mode CVode first hands back a step it took earlier but
  // returned only up to an interpolated output time: not a new step.
  if (r.t <= t_last_step_) return;
  r.h = r.t - t_last_step_;
  t_last_step_ = r.t;
  if (CVodeGetEstLocalErrors(cvode_mem_, scratch_error_.get()) >= 0 &&
      CVodeGetErrWeights(cvode_mem_, scratch_weights_.get()) >= 0)
    r.error = N_VWrmsNorm(scratch_error_.get(), scratch_weights_.get());
  options_.on_step(r);
}

// At most kPollSteps steps between calls of poll(), and max_steps holds
// exactly over the whole run.
double CvodeIntegrator::advance(double t_out, std::span<double> y) {
  if (options_.on_step) return advance_stepwise(t_out, y);
  double t = 0.0;
  int flag = CV_SUCCESS;
  for (;;) {
    long taken = 0;
    CVodeGetNumSteps(cvode_mem_, &taken);
    if (taken >= solver_.max_steps) {
      double now = 0.0, last = 0.0;
      CVodeGetCurrentTime(cvode_mem_, &now);
      CVodeGetLastStep(cvode_mem_, &last);
      throw IntegrationError(describe_out_of_steps(now, taken, last));
    }
    check(CVodeSetMaxNumSteps(cvode_mem_, std::min(kPollSteps, solver_.max_steps - taken)),
          "CVodeSetMaxNumSteps");
    flag = CVode(cvode_mem_, t_out, y_.get(), &t, CV_NORMAL);
    if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
    if (flag != CV_TOO_MUCH_WORK) break;
    if (options_.poll && options_.poll()) break;  // y_ holds the state at t, the last step's end
  }
  if (flag < 0 && flag != CV_TOO_MUCH_WORK) throw_failure(flag, t);
  std::fill(roots_.begin(), roots_.end(), 0);
  if (flag == CV_ROOT_RETURN)
    check(CVodeGetRootInfo(cvode_mem_, roots_.data()), "CVodeGetRootInfo");
  const auto values = as_span(y_.get());
  std::copy(values.begin(), values.end(), y.begin());
  return flag == CV_ROOT_RETURN || flag == CV_TOO_MUCH_WORK ? t : t_out;
}

// CVODE has no hook after each step, so when steps are recorded it is driven
// one step at a time (CV_ONE_STEP) and outputs are interpolated, exactly as
// CV_NORMAL does internally. A root that the step crossing t_out finds beyond
// t_out is kept and reported by the next call.
double CvodeIntegrator::advance_stepwise(double t_out, std::span<double> y) {
  std::fill(roots_.begin(), roots_.end(), 0);
  auto finish = [&](double t) {
    const auto values = as_span(y_.get());
    std::copy(values.begin(), values.end(), y.begin());
    return t;
  };
  if (pending_root_) {
    if (pending_t_ <= t_out) {
      pending_root_ = false;
      roots_ = pending_roots_;
      N_VScale(1.0, pending_y_.get(), y_.get());
      return finish(pending_t_);
    }
    check(CVodeGetDky(cvode_mem_, t_out, 0, y_.get()), "CVodeGetDky");
    return finish(t_out);
  }
  long since_poll = 0;
  for (;;) {
    double t_now = 0.0, t = 0.0;
    CVodeGetCurrentTime(cvode_mem_, &t_now);
    if (t_now >= t_out) {
      // t_out lies in the last step: roots up to it, then its interpolated state.
      const int flag = CVode(cvode_mem_, t_out, y_.get(), &t, CV_NORMAL);
      if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
      if (flag < 0) throw_failure(flag, t);
      if (flag == CV_ROOT_RETURN)
        check(CVodeGetRootInfo(cvode_mem_, roots_.data()), "CVodeGetRootInfo");
      return finish(flag == CV_ROOT_RETURN ? t : t_out);
    }
    long taken = 0;
    CVodeGetNumSteps(cvode_mem_, &taken);
    if (taken >= solver_.max_steps) {
      double last = 0.0;
      CVodeGetLastStep(cvode_mem_, &last);
      throw IntegrationError(describe_out_of_steps(t_now, taken, last));
    }
    if (++since_poll >= kPollSteps) {
      since_poll = 0;
      if (options_.poll && options_.poll()) return finish(t_now);  // y_ holds the state at t_now
    }
    const int flag = CVode(cvode_mem_, t_out, y_.get(), &t, CV_ONE_STEP);
    if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
    if (flag < 0) throw_failure(flag, t);
    record_step();
    if (flag != CV_ROOT_RETURN) continue;
    check(CVodeGetRootInfo(cvode_mem_, roots_.data()), "CVodeGetRootInfo");
    if (t <= t_out) return finish(t);
    // The root lies beyond t_out: report t_out first (still inside this step).
    pending_root_ = true;
    pending_t_ = t;
    pending_roots_ = roots_;
    N_VScale(1.0, y_.get(), pending_y_.get());
    std::fill(roots_.begin(), roots_.end(), 0);
    check(CVodeGetDky(cvode_mem_, t_out, 0, y_.get()), "CVodeGetDky");
    return finish(t_out);
  }
}

void CvodeIntegrator::throw_failure(int flag, double t) {
  NVectorPtr err(N_VClone(y_.get())), weights(N_VClone(y_.get()));
  const bool have = CVodeGetEstLocalErrors(cvode_mem_, err.get()) >= 0 &&
                    CVodeGetErrWeights(cvode_mem_, weights.get()) >= 0;
  throw IntegrationError(describe_failure(system_, "CVode", CVodeGetReturnFlagName(flag), t,
                                          err.get(), weights.get(), have));
}

SolverStats CvodeIntegrator::stats() const {
  SolverStats s;
  CVodeGetNumSteps(cvode_mem_, &s.steps);
  CVodeGetNumRhsEvals(cvode_mem_, &s.rhs_implicit);
  CVodeGetNumNonlinSolvIters(cvode_mem_, &s.newton_iterations);
  CVodeGetNumNonlinSolvConvFails(cvode_mem_, &s.convergence_failures);
  CVodeGetNumLinSolvSetups(cvode_mem_, &s.linear_setups);
  CVodeGetNumJacEvals(cvode_mem_, &s.jacobian_evaluations);
  CVodeGetNumErrTestFails(cvode_mem_, &s.error_test_failures);
  if (!roots_.empty()) CVodeGetNumGEvals(cvode_mem_, &s.root_evaluations);
  CVodeGetLastStep(cvode_mem_, &s.last_step);
  s.step_attempts = s.steps + s.error_test_failures + s.convergence_failures;
  return s;
}

nlohmann::json CvodeIntegrator::description() const {
  nlohmann::json d = {
      {"method", "bdf"},
      {"integrator", "CVODE variable-order BDF, Newton with KLU on the sparse Jacobian"},
      {"max_order", max_order_},
      {"stability_limit_detection", max_order_ >= 3},
      {"adaptive", true},
      {"rtol", solver_.rtol},
      {"atol_displacement", solver_.atol_displacement},
      {"atol_velocity", solver_.atol_velocity}};
  return d;
}

}  // namespace stickslip
