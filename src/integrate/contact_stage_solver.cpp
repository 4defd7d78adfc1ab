#include "stickslip/integrate/contact_stage_solver.hpp"

#include <arkode/arkode_arkstep.h>

#include "stickslip/integrate/sundials.hpp"

namespace stickslip {
namespace {

struct Content {
  const System* system;
  ContactStageStats* stats;
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

// ARKStep's stage equation in its corrector form (arkode_arkstep_nls.c):
//     zcor − γ f_I(zpred + zcor) − sdata = 0,
// i.e. z − γ f_I(z) = zpred + sdata =: b for the stage value z = zpred + zcor.
int solve(SUNNonlinearSolver nls, N_Vector, N_Vector zcor, N_Vector, double, sunbooleantype,
          void* arkode_mem) {
  Content& c = content(nls);
  double t = 0.0, gamma = 0.0;
  N_Vector zpred = nullptr, z = nullptr, fi = nullptr, sdata = nullptr;
  void* user_data = nullptr;
  if (ARKStepGetNonlinearSystemData(arkode_mem, &t, &zpred, &z, &fi, &gamma, &sdata, &user_data) <
      0)
    return SUN_NLS_MEM_NULL;
  // Two passes over the state: b into z (every entry but the contacts' is
  // then final), and the correction out of it.
  N_VLinearSum(1.0, zpred, 1.0, sdata, z);
  ++c.stats->solves;
  try {
    c.stats->last_iterations = c.system->solve_implicit_stage(gamma, as_span(zpred), as_span(z));
  } catch (const std::exception&) {
    ++c.stats->failures;
    return SUN_NLS_CONV_RECVR;  // ARKStep retries with a smaller step
  }
  c.stats->scalar_iterations += c.stats->last_iterations;
  N_VLinearSum(1.0, z, -1.0, zpred, zcor);
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

NonlinearSolverPtr make_contact_stage_solver(SUNContext ctx, const System& system,
                                             ContactStageStats& stats) {
  SUNNonlinearSolver nls = SUNNonlinSolNewEmpty(ctx);
  check_created(nls, "SUNNonlinSolNewEmpty");
  nls->content = new Content{&system, &stats};
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
