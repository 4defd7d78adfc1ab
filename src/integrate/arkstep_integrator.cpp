#include "stickslip/integrate/arkstep_integrator.hpp"

#include <arkode/arkode_arkstep.h>
#include <arkode/arkode_butcher.h>

#include <stdexcept>

#include "stickslip/integrate/dirk_tables.hpp"

namespace stickslip {
namespace {

// The classic fourth-order Runge–Kutta tableau (no embedding: fixed step only).
ARKodeButcherTable classic_rk4() {
  const double c[4] = {0.0, 0.5, 0.5, 1.0};
  const double a[16] = {0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 1.0, 0};
  const double b[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};
  return ARKodeButcherTable_Create(4, 4, 0, const_cast<double*>(c), const_cast<double*>(a),
                                   const_cast<double*>(b), nullptr);
}

}  // namespace

ArkStepIntegrator::ArkStepIntegrator(const System& system, const SolverParams& solver,
                                     std::span<const double> y0, double t0, double t_stop,
                                     IntegratorOptions options)
    : SteppingIntegrator(system, solver, std::move(options), t0, t_stop) {
  y_ = make_serial_vector(y0, ctx_);
  // Which parts ARKStep sees: explicit methods all of f explicitly, imex the
  // contact forces implicitly and the rest explicitly, dirk all implicitly.
  const StageSolve stages = stages_;
  ARKRhsFn fe = stages == StageSolve::none          ? full_rhs
                : stages == StageSolve::per_contact ? explicit_rhs
                                                    : nullptr;
  ARKRhsFn fi = stages == StageSolve::none          ? nullptr
                : stages == StageSolve::per_contact ? implicit_rhs
                                                    : full_rhs;
  arkode_mem_.reset(ARKStepCreate(fe, fi, t0, y_.get(), ctx_));
  check_created(arkode_mem_.get(), "ARKStepCreate");
  // First, so that every later call's error message reaches its exception.
  check(ARKStepSetErrHandlerFn(arkode_mem_.get(), record_solver_message, &message_),
        "ARKStepSetErrHandlerFn");
  check(ARKStepSetUserData(arkode_mem_.get(), user_data()), "ARKStepSetUserData");
  atol_ = make_serial_vector(absolute_tolerances(system, solver), ctx_);
  check(ARKStepSVtolerances(arkode_mem_.get(), solver.rtol, atol_.get()), "ARKStepSVtolerances");
  check(ARKStepSetStopTime(arkode_mem_.get(), t_stop), "ARKStepSetStopTime");

  if (solver.method == Method::rk4) {  // ARKStep has no table of its own for it
    ARKodeButcherTable table = classic_rk4();
    check_created(table, "ARKodeButcherTable_Create");
    const int flag = ARKStepSetTables(arkode_mem_.get(), 4, 0, nullptr, table);
    ARKodeButcherTable_Free(table);  // ARKStep keeps its own copy
    check(flag, "ARKStepSetTables");
  } else if (fe == nullptr) {
    check(ARKStepSetTableNum(arkode_mem_.get(), dirk_table(solver.order), ARKODE_ERK_NONE),
          "ARKStepSetTableNum");
  } else if (solver.order > 0) {
    check(ARKStepSetOrder(arkode_mem_.get(), solver.order), "ARKStepSetOrder");
  }
  if (solver.step > 0)
    check(ARKStepSetFixedStep(arkode_mem_.get(), solver.step), "ARKStepSetFixedStep");

  switch (stages) {
    case StageSolve::none:
      break;
    case StageSolve::per_contact:
      // Stages solved exactly, contact by contact.
      make_per_contact_stages(StagePackage::arkstep);
      check(ARKStepSetNonlinearSolver(arkode_mem_.get(), stage_solver_.get()),
            "ARKStepSetNonlinearSolver");
      break;
    case StageSolve::exact_lattice:
      // Steps grow to ~1e-4 s while the contacts creep; where a slip starts
      // they must shrink by 1e5 within one step, more than the default 7
      // error-test failures (each cuts h by at most 10×) allow.
      check(ARKStepSetMaxErrTestFails(arkode_mem_.get(), kMaxErrorTestFailures),
            "ARKStepSetMaxErrTestFails");
      check(ARKStepSetMaxConvFails(arkode_mem_.get(), kMaxStageFailures), "ARKStepSetMaxConvFails");
      make_lattice_stages(StagePackage::arkstep);
      check(ARKStepSetNonlinearSolver(arkode_mem_.get(), stage_solver_.get()),
            "ARKStepSetNonlinearSolver");
      // The stage solve is exact up to 1e-6 of the error weights, so f at the
      // stage is (z − z_pred − data)/γ: ARKStep need not evaluate it (one rhs
      // of a stage's ~6).
      check(ARKStepSetDeduceImplicitRhs(arkode_mem_.get(), SUNTRUE), "ARKStepSetDeduceImplicitRhs");
      break;
  }

  init_stepping(options_.watched_contacts.size());
  if (!roots_.empty())
    check(ARKStepRootInit(arkode_mem_.get(), static_cast<int>(roots_.size()), root_fn),
          "ARKStepRootInit");
}

void ArkodeMemDeleter::operator()(void* mem) const {
  ARKStepFree(&mem);
}

double ArkStepIntegrator::current_time() const {
  double t = 0.0;
  ARKStepGetCurrentTime(arkode_mem_.get(), &t);
  return t;
}

long ArkStepIntegrator::steps_taken() const {
  long n = 0;
  ARKStepGetNumSteps(arkode_mem_.get(), &n);
  return n;
}

double ArkStepIntegrator::last_step_size() const {
  double h = 0.0;
  ARKStepGetLastStep(arkode_mem_.get(), &h);
  return h;
}

void ArkStepIntegrator::set_max_steps(long steps) {
  check(ARKStepSetMaxNumSteps(arkode_mem_.get(), steps), "ARKStepSetMaxNumSteps");
}

int ArkStepIntegrator::evolve(double t_out, double* t, bool one_step) {
  static_assert(ARK_SUCCESS == kSuccess && ARK_TSTOP_RETURN == kStopTime &&
                ARK_ROOT_RETURN == kRoot && ARK_TOO_MUCH_WORK == kTooMuchWork);
  const int flag =
      ARKStepEvolve(arkode_mem_.get(), t_out, y_.get(), t, one_step ? ARK_ONE_STEP : ARK_NORMAL);
  rethrow_pending();
  return flag;
}

void ArkStepIntegrator::root_info(int* roots) {
  check(ARKStepGetRootInfo(arkode_mem_.get(), roots), "ARKStepGetRootInfo");
}

void ArkStepIntegrator::interpolate(double t, N_Vector y) {
  check(ARKStepGetDky(arkode_mem_.get(), t, 0, y), "ARKStepGetDky");
}

bool ArkStepIntegrator::local_errors(N_Vector error, N_Vector weights) const {
  return ARKStepGetEstLocalErrors(arkode_mem_.get(), error) >= 0 &&
         ARKStepGetErrWeights(arkode_mem_.get(), weights) >= 0;
}

const char* ArkStepIntegrator::evolve_name() const {
  return "ARKStepEvolve";
}

std::string ArkStepIntegrator::flag_name(int flag) const {
  return stickslip::flag_name(ARKStepGetReturnFlagName, flag);
}

SolverStats ArkStepIntegrator::stats() const {
  SolverStats s;
  long expl = 0, acc = 0;
  double h0 = 0, hcur = 0, tcur = 0;
  ARKStepGetStepStats(arkode_mem_.get(), &s.steps, &h0, &s.last_step, &hcur, &tcur);
  ARKStepGetTimestepperStats(arkode_mem_.get(), &expl, &acc, &s.step_attempts, &s.rhs_explicit,
                             &s.rhs_implicit, &s.linear_setups, &s.error_test_failures);
  ARKStepGetNumStepSolveFails(arkode_mem_.get(), &s.convergence_failures);
  if (!roots_.empty()) ARKStepGetNumGEvals(arkode_mem_.get(), &s.root_evaluations);
  add_stage_stats(s);
  return s;
}

nlohmann::json ArkStepIntegrator::description() const {
  ARKodeButcherTable bi = nullptr, be = nullptr;
  ARKStepGetCurrentButcherTables(arkode_mem_.get(), &bi, &be);
  const int order = bi ? bi->q : (be ? be->q : 0);
  nlohmann::json d = {{"method", method_.name},
                      {"integrator", integrator_text(solver_.method, solver_.linear_solver)},
                      {"order", order},
                      {"stages", bi ? bi->stages : (be ? be->stages : 0)}};
  return d;
}

}  // namespace stickslip
