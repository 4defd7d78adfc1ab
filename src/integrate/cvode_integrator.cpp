#include "stickslip/integrate/cvode_integrator.hpp"

#include <cvode/cvode.h>

#include <stdexcept>

namespace stickslip {

namespace {

// The calls of CVODE the driver makes (stepping_integrator.hpp).
constexpr PackageCalls kCvodeCalls{
    .prefix = "CVode",
    .evolve_name = "CVode",
    .stage_package = StagePackage::cvode,
    .evolve = CVode,
    .one_step_task = CV_ONE_STEP,
    .normal_task = CV_NORMAL,
    .get_current_time = CVodeGetCurrentTime,
    .get_num_steps = CVodeGetNumSteps,
    .get_last_step = CVodeGetLastStep,
    .set_max_num_steps = CVodeSetMaxNumSteps,
    .get_root_info = CVodeGetRootInfo,
    .get_dky = CVodeGetDky,
    .get_est_local_errors = CVodeGetEstLocalErrors,
    .get_err_weights = CVodeGetErrWeights,
    .get_return_flag_name = CVodeGetReturnFlagName,
    .set_err_handler_fn = CVodeSetErrHandlerFn,
    .set_user_data = CVodeSetUserData,
    .sv_tolerances = CVodeSVtolerances,
    .set_stop_time = CVodeSetStopTime,
    .root_init = CVodeRootInit,
    .set_max_err_test_fails = CVodeSetMaxErrTestFails,
    .set_max_conv_fails = CVodeSetMaxConvFails,
    .set_nonlinear_solver = CVodeSetNonlinearSolver,
    .free = CVodeFree,
};
static_assert(CV_SUCCESS == SteppingIntegrator::kSuccess &&
              CV_TSTOP_RETURN == SteppingIntegrator::kStopTime &&
              CV_ROOT_RETURN == SteppingIntegrator::kRoot &&
              CV_TOO_MUCH_WORK == SteppingIntegrator::kTooMuchWork);

}  // namespace

CvodeIntegrator::CvodeIntegrator(const System& system, const SolverParams& solver,
                                 std::span<const double> y0, double t0, double t_stop,
                                 IntegratorOptions options)
    : SteppingIntegrator(kCvodeCalls, system, solver, y0, std::move(options), t0, t_stop),
      max_order_(solver.order > 0 ? solver.order : method_.default_order) {
  adopt_package(CVodeCreate(CV_BDF, ctx_), "CVodeCreate");
  check(CVodeInit(mem(), full_rhs, t0, y_.get()), "CVodeInit");
  set_up_package();
  check(CVodeSetMaxOrd(mem(), max_order_), "CVodeSetMaxOrd");
  if (max_order_ >= 3) check(CVodeSetStabLimDet(mem(), SUNTRUE), "CVodeSetStabLimDet");
  if (stages_ != StageSolve::exact_lattice)
    throw std::logic_error("CVODE integrates only methods whose whole f is implicit");
  solve_lattice();  // as dirk's: a slip's onset needs more cuts of h
}

SolverStats CvodeIntegrator::stats() const {
  SolverStats s;
  CVodeGetNumSteps(mem(), &s.steps);
  CVodeGetNumRhsEvals(mem(), &s.rhs_implicit);
  CVodeGetNumNonlinSolvConvFails(mem(), &s.convergence_failures);
  add_stage_stats(s);
  CVodeGetNumErrTestFails(mem(), &s.error_test_failures);
  if (!roots().empty()) CVodeGetNumGEvals(mem(), &s.root_evaluations);
  CVodeGetLastStep(mem(), &s.last_step);
  s.step_attempts = s.steps + s.error_test_failures + s.convergence_failures;
  return s;
}

nlohmann::json CvodeIntegrator::description() const {
  nlohmann::json d = {{"method", method_.name},
                      {"integrator", integrator_text(solver_.method, solver_.linear_solver)},
                      {"max_order", max_order_},
                      {"stability_limit_detection", max_order_ >= 3}};
  return d;
}

}  // namespace stickslip
