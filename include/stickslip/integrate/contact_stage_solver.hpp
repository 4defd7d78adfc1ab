#pragma once
// A SUNNonlinearSolver for ARKStep's IMEX stages that solves them exactly with
// System::solve_implicit_stage: the implicit part is the contact forces, which
// decouple into one scalar equation per contact, so no Jacobian, matrix or
// linear solver is needed at all.

#include <sundials/sundials_nonlinearsolver.h>

#include <memory>
#include <type_traits>

#include "stickslip/model/system.hpp"

namespace stickslip {

struct NonlinearSolverDeleter {
  void operator()(SUNNonlinearSolver s) const { SUNNonlinSolFree(s); }
};
using NonlinearSolverPtr =
    std::unique_ptr<std::remove_pointer_t<SUNNonlinearSolver>, NonlinearSolverDeleter>;

struct ContactStageStats {
  long solves = 0;
  long scalar_iterations = 0;
  long failures = 0;
  long last_iterations = 0;
};

// `stats` must outlive the solver. Works only with ARKStep (it reads the stage
// data through ARKStepGetNonlinearSystemData).
NonlinearSolverPtr make_contact_stage_solver(SUNContext ctx, const System& system,
                                             ContactStageStats& stats);

}  // namespace stickslip
