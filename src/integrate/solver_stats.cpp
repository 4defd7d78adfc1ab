#include "stickslip/integrate/solver_stats.hpp"

namespace stickslip {

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
  a.partition_work += b.partition_work;
  if (b.last_step != 0.0) a.last_step = b.last_step;
  return a;
}

}  // namespace stickslip
