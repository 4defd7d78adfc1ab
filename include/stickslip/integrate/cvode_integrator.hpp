#pragma once
// CVODE adapter for bdf: variable-order BDF, its corrector solved exactly
// (LatticeStageSolver) or by Newton with KLU on the sparse Jacobian.

#include <exception>
#include <vector>

#include "stickslip/integrate/exact_stage_solver.hpp"
#include "stickslip/integrate/lattice_stage_solver.hpp"
#include "stickslip/integrate/stepping_integrator.hpp"
#include "stickslip/integrate/sundials.hpp"

namespace stickslip {

class CvodeIntegrator final : public SteppingIntegrator {
 public:
  CvodeIntegrator(const System& system, const SolverParams& solver, std::span<const double> y0,
                  double t0, double t_stop, IntegratorOptions options);
  CvodeIntegrator(const CvodeIntegrator&) = delete;
  CvodeIntegrator& operator=(const CvodeIntegrator&) = delete;

  SolverStats stats() const override;
  nlohmann::json description() const override;

 private:
  static int rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int root_fn(double t, N_Vector y, double* g, void* self);
  static int jacobian(double t, N_Vector y, N_Vector fy, SUNMatrix J, void* self, N_Vector,
                      N_Vector, N_Vector);
  double current_time() const override;
  long steps_taken() const override;
  double last_step_size() const override;
  void set_max_steps(long steps) override;
  int evolve(double t_out, double* t, bool one_step) override;
  void root_info(int* roots) override;
  void interpolate(double t, N_Vector y) override;
  double local_error_norm() override;
  [[noreturn]] void throw_failure(int flag, double t) override;

  MethodSetup setup_;
  int max_order_;
  StageStats stage_stats_;
  std::unique_ptr<LatticeStageSolver> lattice_stages_;
  NonlinearSolverPtr stage_solver_;
  NVectorPtr atol_, scratch_error_, scratch_weights_;
  MatrixPtr matrix_;
  LinearSolverPtr linear_solver_;
  SparseJacobian jacobian_;
  CvodeMemPtr cvode_mem_;  // after what it refers to, so freed before it
  std::exception_ptr pending_;
};

}  // namespace stickslip
