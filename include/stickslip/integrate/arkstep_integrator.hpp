#pragma once
// ARKStep adapter for imex, dirk, erk and rk4 (adaptive or fixed step).

#include <exception>
#include <vector>

#include "stickslip/integrate/contact_stage_solver.hpp"
#include "stickslip/integrate/integrator.hpp"
#include "stickslip/integrate/sundials.hpp"

namespace stickslip {

class ArkStepIntegrator final : public Integrator {
 public:
  ArkStepIntegrator(const System& system, const SolverParams& solver, std::span<const double> y0,
                    double t0, double t_stop, IntegratorOptions options);
  ~ArkStepIntegrator() override;
  ArkStepIntegrator(const ArkStepIntegrator&) = delete;
  ArkStepIntegrator& operator=(const ArkStepIntegrator&) = delete;

  double advance(double t_out, std::span<double> y) override;
  std::span<const int> roots() const override { return roots_; }
  SolverStats stats() const override;
  nlohmann::json description() const override;

 private:
  static int full_rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int explicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int implicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int root_fn(double t, N_Vector y, double* g, void* self);
  double advance_stepwise(double t_out, std::span<double> y);  // when steps are recorded
  void record_step();
  [[noreturn]] void throw_failure(int flag, double t);

  const System& system_;
  SolverParams solver_;
  IntegratorOptions options_;
  SunContext ctx_;
  NVectorPtr y_, atol_, scratch_error_, scratch_weights_, pending_y_;
  ContactStageStats stage_stats_;
  NonlinearSolverPtr stage_solver_;
  MatrixPtr matrix_;
  LinearSolverPtr linear_solver_;
  SparseJacobian jacobian_;
  void* arkode_mem_ = nullptr;
  std::vector<int> roots_;
  std::exception_ptr pending_;
  double t_last_step_;  // end of the previous accepted step, for steps.csv
  // A root found beyond the output time by the step that crossed it.
  bool pending_root_ = false;
  double pending_t_ = 0.0;
  std::vector<int> pending_roots_;
};

}  // namespace stickslip
