#include "stickslip/integrate/exact_stage_solver.hpp"

#include <arkode/arkode_arkstep.h>
#include <cvode/cvode.h>

#include "stickslip/integrate/sundials.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {
namespace {

struct Content {
  StagePackage package;
  ExactStageSolve solve;
  StageStats* stats;
  std::exception_ptr* pending;
};

Content& content(SUNNonlinearSolver nls) {
  return *static_cast<Content*>(nls->content);
}

SUNNonlinearSolver_Type get_type(SUNNonlinearSolver) {
  return SUNNONLINEARSOLVER_ROOTFIND;
}
int succeed(SUNNonlinearSolver) {
  return SUN_NLS_SUCCESS;
}

// Where the stage data live. ARKStep's stage equation in its corrector form
// (arkode_arkstep_nls.c):
//     zcor − γ f_I(zpred + zcor) − sdata = 0,
// i.e. z − γ f_I(z) = zpred + sdata =: b for the stage value z = zpred + zcor.
// CVODE's corrector (cvode_nls.c):
//     rl1 zn[1] + ycor − γ f(ypred + ycor) = 0,
// i.e. y − γ f(y) = ypred − rl1 zn[1] =: b for y = ypred + ycor.
// Either way: b into the package's own stage vector, solved in place (two
// passes over the state), and the correction out of it.
int solve(SUNNonlinearSolver nls, N_Vector, N_Vector correction, N_Vector weights, double,
          sunbooleantype, void* mem) {
  Content& c = content(nls);
  double t = 0.0, gamma = 0.0;
  N_Vector predictor = nullptr, z = nullptr;
  if (c.package == StagePackage::arkstep) {
    N_Vector fi = nullptr, sdata = nullptr;
    void* user_data = nullptr;
    if (ARKStepGetNonlinearSystemData(mem, &t, &predictor, &z, &fi, &gamma, &sdata, &user_data) < 0)
      return SUN_NLS_MEM_NULL;
    N_VLinearSum(1.0, predictor, 1.0, sdata, z);
  } else {
    N_Vector fn = nullptr, zn1 = nullptr;
    double rl1 = 0.0;
    void* user_data = nullptr;
    if (CVodeGetNonlinearSystemData(mem, &t, &predictor, &z, &fn, &gamma, &rl1, &zn1, &user_data) <
        0)
      return SUN_NLS_MEM_NULL;
    N_VLinearSum(1.0, predictor, -rl1, zn1, z);
  }
  ++c.stats->solves;
  const int outcome = guarded(*c.pending, [&] {
    c.stats->last_iterations = c.solve(t, gamma, as_span(predictor), as_span(weights), as_span(z));
  });
  if (outcome > 0) {
    ++c.stats->failures;
    return SUN_NLS_CONV_RECVR;  // the integrator retries with a smaller step
  }
  if (outcome < 0) return SUN_NLS_EXT_FAIL;  // a bug: stop, and say what it was
  c.stats->iterations += c.stats->last_iterations;
  N_VLinearSum(1.0, z, -1.0, predictor, correction);
  return SUN_NLS_SUCCESS;
}

int free_solver(SUNNonlinearSolver nls) {
  delete static_cast<Content*>(nls->content);
  nls->content = nullptr;
  SUNNonlinSolFreeEmpty(nls);
  return SUN_NLS_SUCCESS;
}

int accept_sys_fn(SUNNonlinearSolver, SUNNonlinSolSysFn) {
  return SUN_NLS_SUCCESS;
}
int accept_lsetup_fn(SUNNonlinearSolver, SUNNonlinSolLSetupFn) {
  return SUN_NLS_SUCCESS;
}
int accept_lsolve_fn(SUNNonlinearSolver, SUNNonlinSolLSolveFn) {
  return SUN_NLS_SUCCESS;
}
int accept_ctest_fn(SUNNonlinearSolver, SUNNonlinSolConvTestFn, void*) {
  return SUN_NLS_SUCCESS;
}
int accept_max_iters(SUNNonlinearSolver, int) {
  return SUN_NLS_SUCCESS;
}
int num_iters(SUNNonlinearSolver nls, long* n) {
  *n = content(nls).stats->last_iterations;
  return SUN_NLS_SUCCESS;
}
int cur_iter(SUNNonlinearSolver, int* n) {
  *n = 0;
  return SUN_NLS_SUCCESS;
}
int num_conv_fails(SUNNonlinearSolver nls, long* n) {
  *n = content(nls).stats->failures;
  return SUN_NLS_SUCCESS;
}

}  // namespace

NonlinearSolverPtr make_exact_stage_solver(SUNContext ctx, StagePackage package,
                                           ExactStageSolve solve_stage, StageStats& stats,
                                           std::exception_ptr& pending) {
  SUNNonlinearSolver nls = SUNNonlinSolNewEmpty(ctx);
  check_created(nls, "SUNNonlinSolNewEmpty");
  nls->content = new Content{package, std::move(solve_stage), &stats, &pending};
  nls->ops->gettype = get_type;
  nls->ops->initialize = succeed;
  nls->ops->solve = solve;
  nls->ops->free = free_solver;
  nls->ops->setsysfn = accept_sys_fn;
  nls->ops->setlsetupfn = accept_lsetup_fn;
  nls->ops->setlsolvefn = accept_lsolve_fn;
  nls->ops->setctestfn = accept_ctest_fn;
  nls->ops->setmaxiters = accept_max_iters;
  nls->ops->getnumiters = num_iters;
  nls->ops->getcuriter = cur_iter;
  nls->ops->getnumconvfails = num_conv_fails;
  return NonlinearSolverPtr(nls);
}

}  // namespace stickslip
