#include "stickslip/integrate/arkode_integrator.hpp"

#include <arkode/arkode_arkstep.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <type_traits>
#include <utility>

namespace stickslip {

std::vector<double> absolute_tolerances(const System& system, const SolverParams& solver) {
  const std::int64_t n = system.num_nodes();
  std::vector<double> atol(static_cast<std::size_t>(system.size()));
  std::fill(atol.begin(), atol.begin() + 3 * n, solver.atol_displacement);
  std::fill(atol.begin() + 3 * n, atol.begin() + 6 * n, solver.atol_velocity);
  const double k1 = system.mass() * system.g1() / (system.spacing() * system.spacing());
  const double energy = k1 * system.spacing() * solver.atol_displacement;
  const double c_l = std::sqrt(system.g1() + system.g2());
  atol[system.quadrature_index(System::work_in)] = energy;
  atol[system.quadrature_index(System::dissipated)] = energy;
  atol[system.quadrature_index(System::friction_impulse)] =
      k1 * solver.atol_displacement * system.spacing() / c_l;
  return atol;
}

ArkodeIntegrator::ArkodeIntegrator(const System& system, const SolverParams& solver,
                                   std::span<const double> y0, double t_stop)
    : system_(system), max_steps_(solver.max_steps) {
  y_ = make_serial_vector(y0, ctx_);
  arkode_mem_ = ARKStepCreate(explicit_rhs, implicit_rhs, 0.0, y_.get(), ctx_);
  check_created(arkode_mem_, "ARKStepCreate");
  check(ARKStepSetUserData(arkode_mem_, this), "ARKStepSetUserData");
  const auto atol = absolute_tolerances(system, solver);
  atol_ = make_serial_vector(atol, ctx_);
  check(ARKStepSVtolerances(arkode_mem_, solver.rtol, atol_.get()), "ARKStepSVtolerances");
  check(ARKStepSetStopTime(arkode_mem_, t_stop), "ARKStepSetStopTime");
  check(ARKStepSetMaxNumSteps(arkode_mem_, -1), "ARKStepSetMaxNumSteps");  // we count ourselves

  // Stages solved exactly, contact by contact (contact_stage_solver.hpp).
  nonlinear_solver_ = make_contact_stage_solver(ctx_, system, stage_stats_);
  check(ARKStepSetNonlinearSolver(arkode_mem_, nonlinear_solver_.get()),
        "ARKStepSetNonlinearSolver");
}

ArkodeIntegrator::~ArkodeIntegrator() {
  ARKStepFree(&arkode_mem_);
}

int ArkodeIntegrator::explicit_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<ArkodeIntegrator*>(self);
  return guarded(me->pending_, [&] { me->system_.rhs_explicit(t, as_span(y), as_span(ydot)); });
}

int ArkodeIntegrator::implicit_rhs(double t, N_Vector y, N_Vector ydot, void* self) {
  auto* me = static_cast<ArkodeIntegrator*>(self);
  return guarded(me->pending_, [&] { me->system_.rhs_implicit(t, as_span(y), as_span(ydot)); });
}

void ArkodeIntegrator::advance_to(double t_out, std::span<double> y) {
  double t = 0.0;
  const int flag = ARKStepEvolve(arkode_mem_, t_out, y_.get(), &t, ARK_NORMAL);
  if (pending_) std::rethrow_exception(std::exchange(pending_, nullptr));
  if (flag < 0) fail(flag, t);
  long steps = 0;
  ARKStepGetNumSteps(arkode_mem_, &steps);
  if (steps > max_steps_) {
    throw IntegrationError("stopped at t = " + std::to_string(t) + " s after " +
                           std::to_string(steps) + " steps: more than [solver] max_steps");
  }
  const auto values = as_span(y_.get());
  std::copy(values.begin(), values.end(), y.begin());
}

// Names the time and the components with the largest weighted local error,
// as lattice node and variable, so a user sees where the solution went wrong.
void ArkodeIntegrator::fail(int flag, double t) const {
  std::string msg = std::string("ARKStepEvolve failed at t = ");
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g s", t);
  msg += buf;
  msg += ": ";
  msg += ARKStepGetReturnFlagName(flag);
  NVectorPtr err(N_VClone(y_.get())), weights(N_VClone(y_.get()));
  if (ARKStepGetEstLocalErrors(arkode_mem_, err.get()) >= 0 &&
      ARKStepGetErrWeights(arkode_mem_, weights.get()) >= 0) {
    N_VProd(err.get(), weights.get(), err.get());
    const auto e = as_span(err.get());
    std::vector<std::size_t> order(e.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    const std::size_t shown = std::min<std::size_t>(3, order.size());
    std::partial_sort(order.begin(), order.begin() + shown, order.end(),
                      [&](auto a, auto b) { return std::abs(e[a]) > std::abs(e[b]); });
    msg += "; largest weighted local errors:";
    for (std::size_t k = 0; k < shown; ++k) {
      std::snprintf(buf, sizeof buf, " %.3g at ", std::abs(e[order[k]]));
      msg += buf + system_.describe_component(static_cast<std::int64_t>(order[k]));
    }
  }
  throw IntegrationError(msg);
}

SolverStats ArkodeIntegrator::stats() const {
  SolverStats s;
  long expl = 0, acc = 0;
  double h0 = 0, hcur = 0, tcur = 0;
  ARKStepGetStepStats(arkode_mem_, &s.steps, &h0, &s.last_step, &hcur, &tcur);
  ARKStepGetTimestepperStats(arkode_mem_, &expl, &acc, &s.step_attempts, &s.rhs_explicit,
                             &s.rhs_implicit, &s.linear_setups, &s.error_test_failures);
  s.newton_iterations = stage_stats_.scalar_iterations;
  ARKStepGetNumStepSolveFails(arkode_mem_, &s.newton_convergence_failures);
  return s;
}

std::string ArkodeIntegrator::method_name() const {
  return "ARKStep IMEX additive Runge-Kutta (default order-4 tables): lattice explicit, contact "
         "forces implicit with each stage solved exactly per contact";
}

}  // namespace stickslip
