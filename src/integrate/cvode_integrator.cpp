#include "stickslip/integrate/cvode_integrator.hpp"

#include <cvode/cvode.h>
#include <sunlinsol/sunlinsol_klu.h>

#include <algorithm>
#include <functional>
#include <limits>
#include <utility>

#include "failure.hpp"

namespace stickslip {

CvodeIntegrator::CvodeIntegrator(const System& system, const SolverParams& solver,
                                 std::span<const double> y0, double t0, double t_stop,
                                 IntegratorOptions options)
    : SteppingIntegrator(system, solver, std::move(options), t0, t_stop),
      setup_(method_setup(solver)),
      // BDF of order ≥ 3 is not A-stable and the lattice modes are lightly
      // damped: at loose tolerance it produced spurious slips (MODEL.md §12).
      max_order_(solver.order > 0 ? solver.order : 2) {
  y_ = make_serial_vector(y0, ctx_);
  cvode_mem_.reset(CVodeCreate(CV_BDF, ctx_));
  check_created(cvode_mem_.get(), "CVodeCreate");
  check(CVodeInit(cvode_mem_.get(), rhs, t0, y_.get()), "CVodeInit");
  check(CVodeSetUserData(cvode_mem_.get(), this), "CVodeSetUserData");
  atol_ = make_serial_vector(absolute_tolerances(system, solver), ctx_);
  check(CVodeSVtolerances(cvode_mem_.get(), solver.rtol, atol_.get()), "CVodeSVtolerances");
  check(CVodeSetStopTime(cvode_mem_.get(), t_stop), "CVodeSetStopTime");
  check(CVodeSetErrHandlerFn(cvode_mem_.get(), print_solver_message, nullptr),
        "CVodeSetErrHandlerFn");
  check(CVodeSetMaxOrd(cvode_mem_.get(), max_order_), "CVodeSetMaxOrd");
  if (max_order_ >= 3) check(CVodeSetStabLimDet(cvode_mem_.get(), SUNTRUE), "CVodeSetStabLimDet");

  if (setup_.stages == StageSolve::exact_lattice) {
    check(CVodeSetMaxErrTestFails(cvode_mem_.get(), kMaxErrorTestFailures),
          "CVodeSetMaxErrTestFails");
    check(CVodeSetMaxConvFails(cvode_mem_.get(), kMaxStageFailures), "CVodeSetMaxConvFails");
    lattice_stages_ = std::make_unique<LatticeStageSolver>(system);
    stage_solver_ = make_exact_stage_solver(
        ctx_, StagePackage::cvode,
        std::bind_front(&LatticeStageSolver::solve, lattice_stages_.get()), stage_stats_, pending_);
    check(CVodeSetNonlinearSolver(cvode_mem_.get(), stage_solver_.get()),
          "CVodeSetNonlinearSolver");
  } else {
    jacobian_ = system.jacobian_pattern(JacobianPart::full);
    matrix_ = make_sparse_matrix(jacobian_, ctx_);
    linear_solver_.reset(SUNLinSol_KLU(y_.get(), matrix_.get(), ctx_));
    check_created(linear_solver_.get(), "SUNLinSol_KLU");
    check(CVodeSetLinearSolver(cvode_mem_.get(), linear_solver_.get(), matrix_.get()),
          "CVodeSetLinearSolver");
    check(CVodeSetJacFn(cvode_mem_.get(), jacobian), "CVodeSetJacFn");
  }

  init_stepping(options_.watched_contacts.size());
  if (!roots_.empty())
    check(CVodeRootInit(cvode_mem_.get(), static_cast<int>(roots_.size()), root_fn),
          "CVodeRootInit");
  if (options_.on_step) {
    scratch_error_.reset(N_VClone(y_.get()));
    scratch_weights_.reset(N_VClone(y_.get()));
  }
}

void CvodeMemDeleter::operator()(void* mem) const {
  CVodeFree(&mem);
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

double CvodeIntegrator::current_time() const {
  double t = 0.0;
  CVodeGetCurrentTime(cvode_mem_.get(), &t);
  return t;
}

long CvodeIntegrator::steps_taken() const {
  long n = 0;
  CVodeGetNumSteps(cvode_mem_.get(), &n);
  return n;
}

double CvodeIntegrator::last_step_size() const {
  double h = 0.0;
  CVodeGetLastStep(cvode_mem_.get(), &h);
  return h;
}

void CvodeIntegrator::set_max_steps(long steps) {
  check(CVodeSetMaxNumSteps(cvode_mem_.get(), steps), "CVodeSetMaxNumSteps");
}

int CvodeIntegrator::evolve(double t_out, double* t, bool one_step) {
  static_assert(CV_SUCCESS == kSuccess && CV_TSTOP_RETURN == kStopTime && CV_ROOT_RETURN == kRoot &&
                CV_TOO_MUCH_WORK == kTooMuchWork);
  const int flag = CVode(cvode_mem_.get(), t_out, y_.get(), t, one_step ? CV_ONE_STEP : CV_NORMAL);
  if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
  return flag;
}

void CvodeIntegrator::root_info(int* roots) {
  check(CVodeGetRootInfo(cvode_mem_.get(), roots), "CVodeGetRootInfo");
}

void CvodeIntegrator::interpolate(double t, N_Vector y) {
  check(CVodeGetDky(cvode_mem_.get(), t, 0, y), "CVodeGetDky");
}

double CvodeIntegrator::local_error_norm() {
  if (CVodeGetEstLocalErrors(cvode_mem_.get(), scratch_error_.get()) < 0 ||
      CVodeGetErrWeights(cvode_mem_.get(), scratch_weights_.get()) < 0)
    return std::numeric_limits<double>::quiet_NaN();
  return N_VWrmsNorm(scratch_error_.get(), scratch_weights_.get());
}

void CvodeIntegrator::throw_failure(int flag, double t) {
  NVectorPtr err(N_VClone(y_.get())), weights(N_VClone(y_.get()));
  const bool have = CVodeGetEstLocalErrors(cvode_mem_.get(), err.get()) >= 0 &&
                    CVodeGetErrWeights(cvode_mem_.get(), weights.get()) >= 0;
  throw IntegrationError(describe_failure(system_, "CVode", CVodeGetReturnFlagName(flag), t,
                                          err.get(), weights.get(), have));
}

SolverStats CvodeIntegrator::stats() const {
  SolverStats s;
  CVodeGetNumSteps(cvode_mem_.get(), &s.steps);
  CVodeGetNumRhsEvals(cvode_mem_.get(), &s.rhs_implicit);
  CVodeGetNumNonlinSolvConvFails(cvode_mem_.get(), &s.convergence_failures);
  if (lattice_stages_) {
    s.newton_iterations = stage_stats_.iterations;
    s.linear_setups = lattice_stages_->lattice().factorizations();
    s.jacobian_evaluations = lattice_stages_->contact_factorizations();
  } else {
    CVodeGetNumNonlinSolvIters(cvode_mem_.get(), &s.newton_iterations);
    CVodeGetNumLinSolvSetups(cvode_mem_.get(), &s.linear_setups);
    CVodeGetNumJacEvals(cvode_mem_.get(), &s.jacobian_evaluations);
  }
  CVodeGetNumErrTestFails(cvode_mem_.get(), &s.error_test_failures);
  if (!roots_.empty()) CVodeGetNumGEvals(cvode_mem_.get(), &s.root_evaluations);
  CVodeGetLastStep(cvode_mem_.get(), &s.last_step);
  s.step_attempts = s.steps + s.error_test_failures + s.convergence_failures;
  return s;
}

nlohmann::json CvodeIntegrator::description() const {
  nlohmann::json d = {
      {"method", "bdf"},
      {"integrator", setup_.integrator},
      {"linear_solver", to_string(solver_.linear_solver == LinearSolver::klu ? LinearSolver::klu
                                                                             : LinearSolver::fft)},
      {"max_order", max_order_},
      {"stability_limit_detection", max_order_ >= 3},
      {"adaptive", true},
      {"rtol", solver_.rtol},
      {"atol_displacement", solver_.atol_displacement},
      {"atol_velocity", solver_.atol_velocity}};
  return d;
}

}  // namespace stickslip
