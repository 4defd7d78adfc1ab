#include "stickslip/integrate/cvode_integrator.hpp"

#include <cvode/cvode.h>

#include <stdexcept>

namespace stickslip {

CvodeIntegrator::CvodeIntegrator(const System& system, const SolverParams& solver,
                                 std::span<const double> y0, double t0, double t_stop,
                                 IntegratorOptions options)
    : SteppingIntegrator(system, solver, std::move(options), t0, t_stop),
      max_order_(solver.order > 0 ? solver.order : method_.default_order) {
  y_ = make_serial_vector(y0, ctx_);
  cvode_mem_.reset(CVodeCreate(CV_BDF, ctx_));
  check_created(cvode_mem_.get(), "CVodeCreate");
  // First, so that every later call's error message reaches its exception.
  check(CVodeSetErrHandlerFn(cvode_mem_.get(), record_solver_message, &message_),
        "CVodeSetErrHandlerFn");
  check(CVodeInit(cvode_mem_.get(), full_rhs, t0, y_.get()), "CVodeInit");
  check(CVodeSetUserData(cvode_mem_.get(), user_data()), "CVodeSetUserData");
  atol_ = make_serial_vector(absolute_tolerances(system, solver), ctx_);
  check(CVodeSVtolerances(cvode_mem_.get(), solver.rtol, atol_.get()), "CVodeSVtolerances");
  check(CVodeSetStopTime(cvode_mem_.get(), t_stop), "CVodeSetStopTime");
  check(CVodeSetMaxOrd(cvode_mem_.get(), max_order_), "CVodeSetMaxOrd");
  if (max_order_ >= 3) check(CVodeSetStabLimDet(cvode_mem_.get(), SUNTRUE), "CVodeSetStabLimDet");

  switch (stages_) {
    case StageSolve::exact_lattice:
      // As dirk's (arkstep_integrator.cpp): a slip's onset needs more cuts of h.
      check(CVodeSetMaxErrTestFails(cvode_mem_.get(), kMaxErrorTestFailures),
            "CVodeSetMaxErrTestFails");
      check(CVodeSetMaxConvFails(cvode_mem_.get(), kMaxStageFailures), "CVodeSetMaxConvFails");
      make_lattice_stages(StagePackage::cvode);
      check(CVodeSetNonlinearSolver(cvode_mem_.get(), stage_solver_.get()),
            "CVodeSetNonlinearSolver");
      break;
    case StageSolve::none:
    case StageSolve::per_contact:
      throw std::logic_error("CVODE integrates only methods whose whole f is implicit");
  }

  init_stepping(options_.watched_contacts.size());
  if (!roots_.empty())
    check(CVodeRootInit(cvode_mem_.get(), static_cast<int>(roots_.size()), root_fn),
          "CVodeRootInit");
}

void CvodeMemDeleter::operator()(void* mem) const {
  CVodeFree(&mem);
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
  rethrow_pending();
  return flag;
}

void CvodeIntegrator::root_info(int* roots) {
  check(CVodeGetRootInfo(cvode_mem_.get(), roots), "CVodeGetRootInfo");
}

void CvodeIntegrator::interpolate(double t, N_Vector y) {
  check(CVodeGetDky(cvode_mem_.get(), t, 0, y), "CVodeGetDky");
}

bool CvodeIntegrator::local_errors(N_Vector error, N_Vector weights) const {
  return CVodeGetEstLocalErrors(cvode_mem_.get(), error) >= 0 &&
         CVodeGetErrWeights(cvode_mem_.get(), weights) >= 0;
}

const char* CvodeIntegrator::evolve_name() const {
  return "CVode";
}

std::string CvodeIntegrator::flag_name(int flag) const {
  return stickslip::flag_name(CVodeGetReturnFlagName, flag);
}

SolverStats CvodeIntegrator::stats() const {
  SolverStats s;
  CVodeGetNumSteps(cvode_mem_.get(), &s.steps);
  CVodeGetNumRhsEvals(cvode_mem_.get(), &s.rhs_implicit);
  CVodeGetNumNonlinSolvConvFails(cvode_mem_.get(), &s.convergence_failures);
  add_stage_stats(s);
  CVodeGetNumErrTestFails(cvode_mem_.get(), &s.error_test_failures);
  if (!roots_.empty()) CVodeGetNumGEvals(cvode_mem_.get(), &s.root_evaluations);
  CVodeGetLastStep(cvode_mem_.get(), &s.last_step);
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
