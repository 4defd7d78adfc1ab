#pragma once
// The integration methods a case can ask for ([solver] method) and the linear
// solvers of the implicit ones ([solver] linear_solver), one row each. A row
// is everything the case reader checks, the SUNDIALS adapters set up and
// summary.json says about a method: adding a method is its enumerator in
// case.hpp's Method, its row in methods.cpp, its set-up in the adapter of its
// package (integrate/; a package of its own: a stepper, and its case in
// make_integrator.cpp), and its line in the [solver] documentation of docs/USAGE.md.

#include <span>

#include "stickslip/case/case.hpp"

namespace stickslip {

// The SUNDIALS package that integrates a method.
// `own`: stepped here, not by a SUNDIALS package (multirate).
enum class Package { arkstep, cvode, own };

// How the implicit part of a step is solved.
enum class StageSolve {
  none,           // explicit (erk, rk4)
  per_contact,    // f_I = the contact forces, solved contact by contact (imex)
  exact_lattice,  // f_I = all of f, solved exactly by LatticeStageSolver (dirk, bdf, multirate)
};

struct MethodInfo {
  Method method;
  const char* name;  // in case files and summary.json
  Package package;
  // The orders [solver] order may ask for (SUNDIALS 6.4 offers these), and
  // what order 0 means (0: the package's own default).
  int min_order, max_order, default_order;
  bool error_estimate;  // adaptive steps (without one: a fixed step only)
  bool fixed_step;      // [solver] step > 0 allowed
  // Solves the whole of f implicitly, by the linear solver [solver]
  // linear_solver names (below); otherwise `stages` says how.
  bool whole_implicit;
  StageSolve stages;       // for the others
  const char* integrator;  // summary.json's "integrator"
  const char* implicit;    // what the implicit solve is called there ("stage", "corrector")
  // What the method needs of the case beyond its orders (the reader refuses
  // the rest): single-site contacts (patch = 1), and at least this many
  // nodes along each axis of the lattice.
  bool single_site_only = false;
  int min_nodes = 1;
  // The peak memory a lattice node costs a run of it [bytes], for the
  // reader's estimate: measured peak resident sizes (30×30×10 against
  // 60×60×10, coverage 0.1) grew by 1.7 KiB a node with dirk and 2.2 KiB
  // with multirate (its sub-step state); the other methods need less than dirk.
  double bytes_per_node = 2.0 * 1024;
};

struct LinearSolverInfo {
  LinearSolver solver;
  const char* name;  // in case files and summary.json
  StageSolve stages;
  // Steps between the run's polls (IntegratorOptions::poll): small enough
  // that a stop request is answered within seconds even on a 60×60×10
  // lattice, large enough that returning to the caller costs nothing
  // measurable.
  long poll_steps;
  const char* how;  // ", each <implicit> solved ..." in summary.json's "integrator"
};

// A method's and a linear solver's names in case files and summary.json
// ("auto" for the automatic choices): their rows' names.
const char* to_string(Method m);
const char* to_string(LinearSolver s);

// Every method, in the order of the case file's documentation ("auto" is not
// one: it chooses one, integrate/make_integrator.hpp).
std::span<const MethodInfo> methods();
// Every linear solver ("auto", fft, is not one).
std::span<const LinearSolverInfo> linear_solvers();
// "ARKStep", "CVODE": for messages.
const char* package_name(Package p);
// The row of a method; std::logic_error for Method::automatic.
const MethodInfo& method_info(Method m);
// The row of a linear solver ("auto" is fft).
const LinearSolverInfo& linear_solver_info(LinearSolver s);

// How a resolved method solves its implicit part, with its linear solver.
StageSolve stage_solve(Method m, LinearSolver s);
// Steps between polls for a resolved method and its linear solver.
long poll_steps(Method m, LinearSolver s);
// summary.json's "integrator": the method's, and for whole-implicit methods
// how its linear solver solves each stage.
std::string integrator_text(Method m, LinearSolver s);

}  // namespace stickslip
