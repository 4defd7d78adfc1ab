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
    : system_(system), solver_(solver), options_(std::move(options)), t_last_step_(t0) {
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

  roots_.assign(options_.watched_contacts.size(), 0);
  if (!roots_.empty())
    check(ARKStepRootInit(arkode_mem_, static_cast<int>(roots_.size()), root_fn),
          "ARKStepRootInit");
  if (options_.on_step) {
    scratch_error_.reset(N_VClone(y_.get()));
    scratch_weights_.reset(N_VClone(y_.get()));
    pending_y_.reset(N_VClone(y_.get()));
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

void ArkStepIntegrator::record_step() {
  StepRecord r{0.0, 0.0, std::numeric_limits<double>::quiet_NaN()};
  ARKStepGetCurrentTime(arkode_mem_, &r.t);
  // After a root or an output inside a step, ARK_ONE_STEP first hands back
  // that same step: not a new one.
  if (r.t <= t_last_step_) return;
  r.h = r.t - t_last_step_;
  t_last_step_ = r.t;
  if (solver_.method != Method::rk4 &&
      ARKStepGetEstLocalErrors(arkode_mem_, scratch_error_.get()) >= 0 &&
      ARKStepGetErrWeights(arkode_mem_, scratch_weights_.get()) >= 0)
    r.error = N_VWrmsNorm(scratch_error_.get(), scratch_weights_.get());
  options_.on_step(r);
}

// With steps recorded, ARKStep is driven one step at a time (ARK_ONE_STEP)
// and outputs are interpolated, exactly as ARK_NORMAL does internally. (A
// post-step hook, ARKStepSetPostprocessStepFn, would be simpler, but with it
// ARKStep re-evaluates the right-hand side at every step's end, which changes
// the dense output: thousands of spurious stick/slip events on a 10×10×4
// lattice where there are none.) A root that the step crossing t_out finds
// beyond t_out is kept and reported by the next call.
double ArkStepIntegrator::advance_stepwise(double t_out, std::span<double> y) {
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
    check(ARKStepGetDky(arkode_mem_, t_out, 0, y_.get()), "ARKStepGetDky");
    return finish(t_out);
  }
  long since_poll = 0;
  for (;;) {
    double t_now = 0.0, t = 0.0;
    ARKStepGetCurrentTime(arkode_mem_, &t_now);
    if (t_now >= t_out) {
      // t_out lies in the last step: roots up to it, then its interpolated state.
      const int flag = ARKStepEvolve(arkode_mem_, t_out, y_.get(), &t, ARK_NORMAL);
      if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
      if (flag < 0) throw_failure(flag, t);
      if (flag == ARK_ROOT_RETURN)
        check(ARKStepGetRootInfo(arkode_mem_, roots_.data()), "ARKStepGetRootInfo");
      return finish(flag == ARK_ROOT_RETURN ? t : t_out);
    }
    long taken = 0;
    ARKStepGetNumSteps(arkode_mem_, &taken);
    if (taken >= solver_.max_steps) {
      double last = 0.0;
      ARKStepGetLastStep(arkode_mem_, &last);
      throw IntegrationError(describe_out_of_steps(t_now, taken, last));
    }
    if (++since_poll >= kPollSteps) {
      since_poll = 0;
      if (options_.poll && options_.poll()) return finish(t_now);  // y_ holds the state at t_now
    }
    const int flag = ARKStepEvolve(arkode_mem_, t_out, y_.get(), &t, ARK_ONE_STEP);
    if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
    if (flag < 0) throw_failure(flag, t);
    record_step();
    if (flag != ARK_ROOT_RETURN) continue;
    check(ARKStepGetRootInfo(arkode_mem_, roots_.data()), "ARKStepGetRootInfo");
    if (t <= t_out) return finish(t);
    // The root lies beyond t_out: report t_out first (still inside this step).
    pending_root_ = true;
    pending_t_ = t;
    pending_roots_ = roots_;
    N_VScale(1.0, y_.get(), pending_y_.get());
    std::fill(roots_.begin(), roots_.end(), 0);
    check(ARKStepGetDky(arkode_mem_, t_out, 0, y_.get()), "ARKStepGetDky");
    return finish(t_out);
  }
}

void ArkStepIntegrator::throw_failure(int flag, double t) {
  NVectorPtr err(N_VClone(y_.get())), weights(N_VClone(y_.get()));
  const bool have = ARKStepGetEstLocalErrors(arkode_mem_, err.get()) >= 0 &&
                    ARKStepGetErrWeights(arkode_mem_, weights.get()) >= 0;
  throw IntegrationError(describe_failure(system_, "ARKStepEvolve", ARKStepGetReturnFlagName(flag),
                                          t, err.get(), weights.get(), have));
}

double ArkStepIntegrator::advance(double t_out, std::span<double> y) {
  if (options_.on_step) return advance_stepwise(t_out, y);
  double t = 0.0;
  int flag = ARK_SUCCESS;
  // At most kPollSteps steps per call, so poll() is asked between them and
  // max_steps holds exactly over the whole run.
  for (;;) {
    long taken = 0;
    ARKStepGetNumSteps(arkode_mem_, &taken);
    if (taken >= solver_.max_steps) {
      double now = 0.0, last = 0.0;
      ARKStepGetCurrentTime(arkode_mem_, &now);
      ARKStepGetLastStep(arkode_mem_, &last);
      throw IntegrationError(describe_out_of_steps(now, taken, last));
    }
    check(ARKStepSetMaxNumSteps(arkode_mem_, std::min(kPollSteps, solver_.max_steps - taken)),
          "ARKStepSetMaxNumSteps");
    flag = ARKStepEvolve(arkode_mem_, t_out, y_.get(), &t, ARK_NORMAL);
    if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
    if (flag != ARK_TOO_MUCH_WORK) break;
    if (options_.poll && options_.poll()) break;  // y_ holds the state at t, the last step's end
  }
  if (flag < 0 && flag != ARK_TOO_MUCH_WORK) throw_failure(flag, t);
  std::fill(roots_.begin(), roots_.end(), 0);
  if (flag == ARK_ROOT_RETURN)
    check(ARKStepGetRootInfo(arkode_mem_, roots_.data()), "ARKStepGetRootInfo");
  const auto values = as_span(y_.get());
  std::copy(values.begin(), values.end(), y.begin());
  return flag == ARK_ROOT_RETURN || flag == ARK_TOO_MUCH_WORK ? t : t_out;
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
