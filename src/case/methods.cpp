#include "stickslip/case/methods.hpp"

#include <stdexcept>
#include <string>

namespace stickslip {

namespace {

// clang-format off
constexpr MethodInfo kMethods[] = {
    // method        name    package           orders     error  fixed  whole  stages
    {Method::imex, "imex", Package::arkstep, 3, 5, 0, true,  true,  false, StageSolve::per_contact,
     "ARKStep IMEX additive Runge-Kutta: lattice explicit, contact forces implicit, each stage "
     "solved exactly contact by contact", "stage"},
    // dirk's default order 4: ESDIRK436L2SA (arkstep_integrator.cpp says why these tables).
    {Method::dirk, "dirk", Package::arkstep, 2, 5, 4, true,  true,  true,  StageSolve::none,
     "ARKStep diagonally implicit Runge-Kutta", "stage"},
    // BDF of order ≥ 3 is not A-stable and the lattice modes are lightly
    // damped: at loose tolerance it produced spurious slips (MODEL.md §12).
    {Method::bdf,  "bdf",  Package::cvode,   1, 5, 2, true,  false, true,  StageSolve::none,
     "CVODE variable-order BDF", "corrector"},
    {Method::erk,  "erk",  Package::arkstep, 2, 8, 0, true,  true,  false, StageSolve::none,
     "ARKStep explicit Runge-Kutta", "stage"},
    {Method::rk4,  "rk4",  Package::arkstep, 4, 4, 4, false, true,  false, StageSolve::none,
     "classic fourth-order Runge-Kutta (ARKStep)", "stage"},
    // dirk's ESDIRK (orders 3, 4) for the lattice and the slow contacts, each
    // fast contact on sub-steps of its own (integrate/multirate_integrator.hpp).
    {Method::multirate, "multirate", Package::own, 3, 4, 4, true, false, false,
     StageSolve::exact_lattice,
     "multirate ESDIRK: lattice and slow contacts on coarse steps solved exactly (lattice by "
     "FFT, contacts by Newton on their coupled speeds), each fast contact on adaptive sub-steps "
     "of its own", "stage",
     // It sub-steps a contact node alone, its neighbours given: a patch's
     // nodes are each other's neighbours, and a one-layer lattice's contact
     // nodes are driven (integrate/contact_substeps.hpp).
     /*single_site_only=*/true, /*min_nodes=*/2, /*bytes_per_node=*/2.5 * 1024},
};

constexpr LinearSolverInfo kLinearSolvers[] = {
    {LinearSolver::fft, "fft", StageSolve::exact_lattice, 500,
     " solved exactly: lattice by FFT, contacts by Newton on their coupled speeds"},
};
// clang-format on

}  // namespace

std::span<const MethodInfo> methods() {
  return kMethods;
}

std::span<const LinearSolverInfo> linear_solvers() {
  return kLinearSolvers;
}

const char* package_name(Package p) {
  return p == Package::cvode ? "CVODE" : p == Package::own ? "stickslip" : "ARKStep";
}

const MethodInfo& method_info(Method m) {
  for (const auto& row : kMethods)
    if (row.method == m) return row;
  throw std::logic_error("method_info: resolve \"auto\" first");
}

const LinearSolverInfo& linear_solver_info(LinearSolver s) {
  const LinearSolver resolved = s == LinearSolver::automatic ? LinearSolver::fft : s;
  for (const auto& row : kLinearSolvers)
    if (row.solver == resolved) return row;
  throw std::logic_error("linear_solver_info: no such linear solver");
}

StageSolve stage_solve(Method m, LinearSolver s) {
  const MethodInfo& method = method_info(m);
  return method.whole_implicit ? linear_solver_info(s).stages : method.stages;
}

long poll_steps(Method m, LinearSolver s) {
  // Explicit and imex steps are cheap: as often as fft's.
  return linear_solver_info(method_info(m).whole_implicit ? s : LinearSolver::fft).poll_steps;
}

std::string integrator_text(Method m, LinearSolver s) {
  const MethodInfo& method = method_info(m);
  std::string text = method.integrator;
  if (!method.whole_implicit) return text;
  return text + ", each " + method.implicit + linear_solver_info(s).how;
}

const char* to_string(Method m) {
  if (m == Method::automatic) return "auto";
  return method_info(m).name;
}

const char* to_string(LinearSolver s) {
  if (s == LinearSolver::automatic) return "auto";
  return linear_solver_info(s).name;
}

}  // namespace stickslip
