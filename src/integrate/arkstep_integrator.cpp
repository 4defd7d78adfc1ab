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

// The calls of ARKStep the driver makes (stepping_integrator.hpp).
constexpr PackageCalls kArkStepCalls{
    .prefix = "ARKStep",
    .evolve_name = "ARKStepEvolve",
    .stage_package = StagePackage::arkstep,
    .evolve = ARKStepEvolve,
    .one_step_task = ARK_ONE_STEP,
    .normal_task = ARK_NORMAL,
    .get_current_time = ARKStepGetCurrentTime,
    .get_num_steps = ARKStepGetNumSteps,
    .get_last_step = ARKStepGetLastStep,
    .set_max_num_steps = ARKStepSetMaxNumSteps,
    .get_root_info = ARKStepGetRootInfo,
    .get_dky = ARKStepGetDky,
    .get_est_local_errors = ARKStepGetEstLocalErrors,
    .get_err_weights = ARKStepGetErrWeights,
    .get_return_flag_name = ARKStepGetReturnFlagName,
    .set_err_handler_fn = ARKStepSetErrHandlerFn,
    .set_user_data = ARKStepSetUserData,
    .sv_tolerances = ARKStepSVtolerances,
    .set_stop_time = ARKStepSetStopTime,
    .root_init = ARKStepRootInit,
    .set_max_err_test_fails = ARKStepSetMaxErrTestFails,
    .set_max_conv_fails = ARKStepSetMaxConvFails,
    .set_nonlinear_solver = ARKStepSetNonlinearSolver,
    .free = ARKStepFree,
};
static_assert(ARK_SUCCESS == SteppingIntegrator::kSuccess &&
              ARK_TSTOP_RETURN == SteppingIntegrator::kStopTime &&
              ARK_ROOT_RETURN == SteppingIntegrator::kRoot &&
              ARK_TOO_MUCH_WORK == SteppingIntegrator::kTooMuchWork);

}  // namespace

ArkStepIntegrator::ArkStepIntegrator(const System& system, const SolverParams& solver,
                                     std::span<const double> y0, double t0, double t_stop,
                                     IntegratorOptions options)
    : SteppingIntegrator(kArkStepCalls, system, solver, y0, std::move(options), t0, t_stop) {
  // Which parts ARKStep sees: explicit methods all of f explicitly, imex the
  // contact forces implicitly and the rest explicitly, dirk all implicitly.
  const StageSolve stages = stages_;
  ARKRhsFn fe = stages == StageSolve::none          ? full_rhs
                : stages == StageSolve::per_contact ? explicit_rhs
                                                    : nullptr;
  ARKRhsFn fi = stages == StageSolve::none          ? nullptr
                : stages == StageSolve::per_contact ? implicit_rhs
                                                    : full_rhs;
  adopt_package(ARKStepCreate(fe, fi, t0, y_.get(), ctx_), "ARKStepCreate");
  set_up_package();

  if (solver.method == Method::rk4) {  // ARKStep has no table of its own for it
    ARKodeButcherTable table = classic_rk4();
    check_created(table, "ARKodeButcherTable_Create");
    const int flag = ARKStepSetTables(mem(), 4, 0, nullptr, table);
    ARKodeButcherTable_Free(table);  // ARKStep keeps its own copy
    check(flag, "ARKStepSetTables");
  } else if (fe == nullptr) {
    check(ARKStepSetTableNum(mem(), dirk_table(solver.order), ARKODE_ERK_NONE),
          "ARKStepSetTableNum");
  } else if (solver.order > 0) {
    check(ARKStepSetOrder(mem(), solver.order), "ARKStepSetOrder");
  }
  if (solver.step > 0) check(ARKStepSetFixedStep(mem(), solver.step), "ARKStepSetFixedStep");

  switch (stages) {
    case StageSolve::none:
      break;
    case StageSolve::per_contact:
      solve_per_contact();
      break;
    case StageSolve::exact_lattice:
      solve_lattice();
      // The stage solve is exact up to 1e-6 of the error weights, so f at the
      // stage is (z − z_pred − data)/γ: ARKStep need not evaluate it (one rhs
      // of a stage's ~6).
      check(ARKStepSetDeduceImplicitRhs(mem(), SUNTRUE), "ARKStepSetDeduceImplicitRhs");
      break;
  }
}

void ArkodeMemDeleter::operator()(void* mem) const {
  ARKStepFree(&mem);
}

SolverStats ArkStepIntegrator::stats() const {
  SolverStats s;
  long expl = 0, acc = 0;
  double h0 = 0, hcur = 0, tcur = 0;
  ARKStepGetStepStats(mem(), &s.steps, &h0, &s.last_step, &hcur, &tcur);
  ARKStepGetTimestepperStats(mem(), &expl, &acc, &s.step_attempts, &s.rhs_explicit, &s.rhs_implicit,
                             &s.linear_setups, &s.error_test_failures);
  ARKStepGetNumStepSolveFails(mem(), &s.convergence_failures);
  if (!roots().empty()) ARKStepGetNumGEvals(mem(), &s.root_evaluations);
  add_stage_stats(s);
  return s;
}

nlohmann::json ArkStepIntegrator::description() const {
  ARKodeButcherTable bi = nullptr, be = nullptr;
  ARKStepGetCurrentButcherTables(mem(), &bi, &be);
  const int order = bi ? bi->q : (be ? be->q : 0);
  nlohmann::json d = {{"method", method_.name},
                      {"integrator", integrator_text(solver_.method, solver_.linear_solver)},
                      {"order", order},
                      {"stages", bi ? bi->stages : (be ? be->stages : 0)}};
  return d;
}

}  // namespace stickslip
