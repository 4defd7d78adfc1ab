#pragma once
// A SUNNonlinearSolver that hands an implicit stage equation,
//     z − γ f_I(t, z) = b,
// to a function that solves it exactly, so SUNDIALS' Newton iteration, its
// Jacobian and its linear solver are never used. imex solves its stages
// contact by contact (System::solve_implicit_stage: its f_I is the contact
// forces alone); dirk and bdf solve theirs with LatticeStageSolver (all of f).
// ARKStep's implicit stages and CVODE's BDF corrector are both of this form;
// only where b, the predictor and the correction live differs.

#include <sundials/sundials_nonlinearsolver.h>

#include <exception>
#include <functional>
#include <memory>
#include <span>
#include <type_traits>

namespace stickslip {

struct NonlinearSolverDeleter {
  void operator()(SUNNonlinearSolver s) const { SUNNonlinSolFree(s); }
};
using NonlinearSolverPtr =
    std::unique_ptr<std::remove_pointer_t<SUNNonlinearSolver>, NonlinearSolverDeleter>;

struct StageStats {
  long solves = 0;
  long iterations = 0;  // of the exact solves (scalar or coupled Newton iterations)
  long failures = 0;
  long last_iterations = 0;
};

// Solves z − γ f_I(t, z) = b: z holds b on entry and the solution on return;
// `predictor` is the integrator's guess, `weights` its error weights. Returns
// iterations; throws StageNotConverged (model/friction_law.hpp) when it fails, and
// the integrator retries with a smaller step.
using ExactStageSolve =
    std::function<long(double t, double gamma, std::span<const double> predictor,
                       std::span<const double> weights, std::span<double> z)>;

enum class StagePackage { arkstep, cvode };

// `stats` must outlive the solver.
// The solve runs through guarded (sundials.hpp): StageNotConverged is a
// recoverable failure, any other exception lands in `pending` and fails the
// step unrecoverably; the adapter rethrows it after the SUNDIALS call returns.
NonlinearSolverPtr make_exact_stage_solver(SUNContext ctx, StagePackage package,
                                           ExactStageSolve solve, StageStats& stats,
                                           std::exception_ptr& pending);

}  // namespace stickslip
