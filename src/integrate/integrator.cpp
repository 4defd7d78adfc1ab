#include "stickslip/integrate/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "stickslip/integrate/arkstep_integrator.hpp"
#include "stickslip/integrate/cvode_integrator.hpp"
#include "stickslip/integrate/multirate_integrator.hpp"

namespace stickslip {

MethodChoice choose_method(const System& system, const SolverParams& solver) {
  if (solver.method != Method::automatic) return {solver.method, "given"};
  if (solver.step > 0)
    return {Method::imex,
            "method = \"auto\" with a fixed step: imex, the cheapest fixed-step "
            "method (docs/PERFORMANCE.md)"};
  std::size_t weak = 0;  // contacts that stick-slip at the drive speed
  for (const auto& c : system.contacts())
    if (c.v_star < system.drive_velocity()) ++weak;
  // bdf rather than dirk: on the 30 points of Fig. 7 at v = 3e-4 both agree
  // to 2.4e-6 in μ, bdf took 1-7 s on each, dirk up to 54 s and stalled on
  // one (its contacts' Newton failing again and again in the creep).
  if (weak == 0)
    return {Method::bdf,
            "method = \"auto\": bdf, since no contact has v* below the drive "
            "speed (steady sliding or creep, where its steps grow; "
            "docs/PERFORMANCE.md)"};
  return {Method::dirk, "method = \"auto\": dirk, since " + std::to_string(weak) + " of " +
                            std::to_string(system.contacts().size()) +
                            " contacts have v* below the drive speed and stick-slip, where dirk "
                            "is the fastest at equal accuracy (docs/PERFORMANCE.md)"};
}

std::unique_ptr<Integrator> make_integrator(const System& system, const SolverParams& solver,
                                            std::span<const double> y0, double t_stop,
                                            IntegratorOptions options, double t0) {
  SolverParams chosen = with_absolute_tolerances(system, solver);
  chosen.method = choose_method(system, solver).method;
  switch (method_info(chosen.method).package) {
    case Package::arkstep:
      return std::make_unique<ArkStepIntegrator>(system, chosen, y0, t0, t_stop,
                                                 std::move(options));
    case Package::cvode:
      return std::make_unique<CvodeIntegrator>(system, chosen, y0, t0, t_stop, std::move(options));
    case Package::own:
      return std::make_unique<MultirateIntegrator>(system, chosen, y0, t0, t_stop,
                                                   std::move(options));
  }
  throw std::logic_error("make_integrator: no adapter for the method's package");
}

SolverStats& operator+=(SolverStats& a, const SolverStats& b) {
  a.steps += b.steps;
  a.step_attempts += b.step_attempts;
  a.rhs_explicit += b.rhs_explicit;
  a.rhs_implicit += b.rhs_implicit;
  a.newton_iterations += b.newton_iterations;
  a.convergence_failures += b.convergence_failures;
  a.linear_setups += b.linear_setups;
  a.jacobian_evaluations += b.jacobian_evaluations;
  a.krylov_iterations += b.krylov_iterations;
  a.error_test_failures += b.error_test_failures;
  a.root_evaluations += b.root_evaluations;
  a.substeps += b.substeps;
  a.substep_failures += b.substep_failures;
  a.fast_contact_steps += b.fast_contact_steps;
  a.coupling_iterations += b.coupling_iterations;
  if (b.last_step != 0.0) a.last_step = b.last_step;
  return a;
}

}  // namespace stickslip
