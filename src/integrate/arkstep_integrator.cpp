#include "stickslip/integrate/arkstep_integrator.hpp"

#include <arkode/arkode_arkstep.h>
#include <arkode/arkode_butcher.h>
#include <sunlinsol/sunlinsol_klu.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "failure.hpp"

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
    : SteppingIntegrator(solver, std::move(options), t0), system_(system) {
  y_ = make_serial_vector(y0, ctx_);
  const Method m = solver.method;
  // Which parts ARKStep sees: erk and rk4 all explicit, dirk all implicit,
  // imex the contact forces implicit and the rest explicit.
  ARKRhsFn fe = m == Method::imex ? explicit_rhs : (m == Method::dirk ? nullptr : full_rhs);
  ARKRhsFn fi = m == Method::imex ? implicit_rhs : (m == Method::dirk ? full_rhs : nullptr);
  arkode_mem_ = ARKStepCreate(fe, fi, t0, y_.get(), ctx_);
  check_created(arkode_mem_, "ARKStepCreate");
  check(ARKStepSetUserData(arkode_mem_, this), "ARKStepSetUserData");
  atol_ = make_serial_vector(absolute_tolerances(system, solver), ctx_);
  check(ARKStepSVtolerances(arkode_mem_, solver.rtol, atol_.get()), "ARKStepSVtolerances");
  check(ARKStepSetStopTime(arkode_mem_, t_stop), "ARKStepSetStopTime");
  check(ARKStepSetErrHandlerFn(arkode_mem_, print_solver_message, nullptr),
        "ARKStepSetErrHandlerFn");

  if (m == Method::rk4) {
    ARKodeButcherTable table = classic_rk4();
    check_created(table, "ARKodeButcherTable_Create");
    const int flag = ARKStepSetTables(arkode_mem_, 4, 0, nullptr, table);
    ARKodeButcherTable_Free(table);  // ARKStep keeps its own copy
    check(flag, "ARKStepSetTables");
  } else if (solver.order > 0) {
    check(ARKStepSetOrder(arkode_mem_, solver.order), "ARKStepSetOrder");
  }
  if (solver.step > 0) check(ARKStepSetFixedStep(arkode_mem_, solver.step), "ARKStepSetFixedStep");

  if (m == Method::imex) {
    // Stages solved exactly, contact by contact (contact_stage_solver.hpp).
    stage_solver_ = make_contact_stage_solver(ctx_, system, stage_stats_);
    check(ARKStepSetNonlinearSolver(arkode_mem_, stage_solver_.get()), "ARKStepSetNonlinearSolver");
  } else if (m == Method::dirk) {
    // Newton with KLU on I − γ J; ARKStep reuses J and KLU its symbolic
    // factorization (the pattern never changes) across steps.
    jacobian_ = system.jacobian_pattern(JacobianPart::full);
    matrix_ = make_sparse_matrix(jacobian_, ctx_);
    linear_solver_.reset(SUNLinSol_KLU(y_.get(), matrix_.get(), ctx_));
    check_created(linear_solver_.get(), "SUNLinSol_KLU");
    check(ARKStepSetLinearSolver(arkode_mem_, linear_solver_.get(), matrix_.get()),
          "ARKStepSetLinearSolver");
    check(ARKStepSetJacFn(arkode_mem_,
                          [](double, N_Vector y, N_Vector, SUNMatrix J, void* self, N_Vector,
                             N_Vector, N_Vector) {
                            auto* me = static_cast<ArkStepIntegrator*>(self);
                            return guarded(me->pending_, [&] {
                              me->system_.jacobian_values(as_span(y), me->jacobian_);
                              copy_into(me->jacobian_, J);
                            });
                          }),
          "ARKStepSetJacFn");
  }

  init_stepping(options_.watched_contacts.size());
  if (!roots_.empty())
    check(ARKStepRootInit(arkode_mem_, static_cast<int>(roots_.size()), root_fn),
          "ARKStepRootInit");
  if (options_.on_step) {
    scratch_error_.reset(N_VClone(y_.get()));
    scratch_weights_.reset(N_VClone(y_.get()));
  }
}

ArkStepIntegrator::~ArkStepIntegrator() {
  ARKStepFree(&arkode_mem_);
}

int ArkStepIntegrator::full_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<ArkStepIntegrator*>(self);
  return guarded(me->pending_, [&] { me->system_.rhs(t, as_span(y), as_span(ydot)); });
}

int ArkStepIntegrator::explicit_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<ArkStepIntegrator*>(self);
  return guarded(me->pending_, [&] { me->system_.rhs_explicit(t, as_span(y), as_span(ydot)); });
}

int ArkStepIntegrator::implicit_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<ArkStepIntegrator*>(self);
  return guarded(me->pending_, [&] { me->system_.rhs_implicit(t, as_span(y), as_span(ydot)); });
}

int ArkStepIntegrator::root_fn(double, N_Vector y, double* g, void* self) {
  auto* me = static_cast<ArkStepIntegrator*>(self);
  return guarded(me->pending_, [&] {
    me->system_.stick_slip_roots(as_span(y), me->options_.watched_contacts,
                                 std::span<double>(g, me->roots_.size()));
  });
}

double ArkStepIntegrator::current_time() const {
  double t = 0.0;
  ARKStepGetCurrentTime(arkode_mem_, &t);
  return t;
}

long ArkStepIntegrator::steps_taken() const {
  long n = 0;
  ARKStepGetNumSteps(arkode_mem_, &n);
  return n;
}

double ArkStepIntegrator::last_step_size() const {
  double h = 0.0;
  ARKStepGetLastStep(arkode_mem_, &h);
  return h;
}

void ArkStepIntegrator::set_max_steps(long steps) {
  check(ARKStepSetMaxNumSteps(arkode_mem_, steps), "ARKStepSetMaxNumSteps");
}

int ArkStepIntegrator::evolve(double t_out, double* t, bool one_step) {
  static_assert(ARK_SUCCESS == kSuccess && ARK_TSTOP_RETURN == kStopTime &&
                ARK_ROOT_RETURN == kRoot && ARK_TOO_MUCH_WORK == kTooMuchWork);
  const int flag =
      ARKStepEvolve(arkode_mem_, t_out, y_.get(), t, one_step ? ARK_ONE_STEP : ARK_NORMAL);
  if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
  return flag;
}

void ArkStepIntegrator::root_info(int* roots) {
  check(ARKStepGetRootInfo(arkode_mem_, roots), "ARKStepGetRootInfo");
}

void ArkStepIntegrator::interpolate(double t, N_Vector y) {
  check(ARKStepGetDky(arkode_mem_, t, 0, y), "ARKStepGetDky");
}

double ArkStepIntegrator::local_error_norm() {
  if (solver_.method == Method::rk4 ||
      ARKStepGetEstLocalErrors(arkode_mem_, scratch_error_.get()) < 0 ||
      ARKStepGetErrWeights(arkode_mem_, scratch_weights_.get()) < 0)
    return std::numeric_limits<double>::quiet_NaN();  // rk4 has no error estimate
  return N_VWrmsNorm(scratch_error_.get(), scratch_weights_.get());
}

void ArkStepIntegrator::throw_failure(int flag, double t) {
  NVectorPtr err(N_VClone(y_.get())), weights(N_VClone(y_.get()));
  const bool have = ARKStepGetEstLocalErrors(arkode_mem_, err.get()) >= 0 &&
                    ARKStepGetErrWeights(arkode_mem_, weights.get()) >= 0;
  throw IntegrationError(describe_failure(system_, "ARKStepEvolve", ARKStepGetReturnFlagName(flag),
                                          t, err.get(), weights.get(), have));
}

SolverStats ArkStepIntegrator::stats() const {
  SolverStats s;
  long expl = 0, acc = 0;
  double h0 = 0, hcur = 0, tcur = 0;
  ARKStepGetStepStats(arkode_mem_, &s.steps, &h0, &s.last_step, &hcur, &tcur);
  ARKStepGetTimestepperStats(arkode_mem_, &expl, &acc, &s.step_attempts, &s.rhs_explicit,
                             &s.rhs_implicit, &s.linear_setups, &s.error_test_failures);
  ARKStepGetNumStepSolveFails(arkode_mem_, &s.convergence_failures);
  if (!roots_.empty()) ARKStepGetNumGEvals(arkode_mem_, &s.root_evaluations);
  if (solver_.method == Method::imex) {
    s.newton_iterations = stage_stats_.scalar_iterations;
  } else if (solver_.method == Method::dirk) {
    ARKStepGetNumNonlinSolvIters(arkode_mem_, &s.newton_iterations);
    ARKStepGetNumJacEvals(arkode_mem_, &s.jacobian_evaluations);
  }
  return s;
}

nlohmann::json ArkStepIntegrator::description() const {
  static const char* const kNames[] = {
      "ARKStep IMEX additive Runge-Kutta: lattice explicit, contact forces implicit, each stage "
      "solved exactly contact by contact",
      "ARKStep diagonally implicit Runge-Kutta, Newton with KLU on the sparse Jacobian",
      "CVODE BDF", "ARKStep explicit Runge-Kutta", "classic fourth-order Runge-Kutta (ARKStep)"};
  ARKodeButcherTable bi = nullptr, be = nullptr;
  ARKStepGetCurrentButcherTables(arkode_mem_, &bi, &be);
  const int order = bi ? bi->q : (be ? be->q : 0);
  nlohmann::json d = {{"method", to_string(solver_.method)},
                      {"integrator", kNames[static_cast<int>(solver_.method)]},
                      {"order", order},
                      {"stages", bi ? bi->stages : (be ? be->stages : 0)}};
  if (solver_.step > 0) {
    d["fixed_step"] = solver_.step;
  } else {
    d["adaptive"] = true;
    d["rtol"] = solver_.rtol;
    d["atol_displacement"] = solver_.atol_displacement;
    d["atol_velocity"] = solver_.atol_velocity;
  }
  return d;
}

}  // namespace stickslip
