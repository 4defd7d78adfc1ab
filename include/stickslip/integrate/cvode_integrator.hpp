#pragma once
// CVODE adapter for bdf: variable-order BDF, Newton with KLU on the sparse Jacobian.

#include <exception>
#include <vector>

#include "stickslip/integrate/integrator.hpp"
#include "stickslip/integrate/sundials.hpp"

namespace stickslip {

class CvodeIntegrator final : public Integrator {
 public:
  CvodeIntegrator(const System& system, const SolverParams& solver, std::span<const double> y0,
                  double t0, double t_stop, IntegratorOptions options);
  ~CvodeIntegrator() override;
  CvodeIntegrator(const CvodeIntegrator&) = delete;
  CvodeIntegrator& operator=(const CvodeIntegrator&) = delete;

  double advance(double t_out, std::span<double> y) override;
  std::span<const int> roots() const override { return roots_; }
  SolverStats stats() const override;
  nlohmann::json description() const override;

 private:
  static int rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int root_fn(double t, N_Vector y, double* g, void* self);
  static int jacobian(double t, N_Vector y, N_Vector fy, SUNMatrix J, void* self, N_Vector,
                      N_Vector, N_Vector);
  double advance_stepwise(double t_out, std::span<double> y);  // when steps are recorded
  void record_step();
  [[noreturn]] void throw_failure(int flag, double t);

  const System& system_;
  SolverParams solver_;
  IntegratorOptions options_;
  double t_last_step_;  // end of the last step written to steps.csv
  int max_order_;
  SunContext ctx_;
  NVectorPtr y_, atol_, scratch_error_, scratch_weights_, pending_y_;
  MatrixPtr matrix_;
  LinearSolverPtr linear_solver_;
  SparseJacobian jacobian_;
  void* cvode_mem_ = nullptr;
  std::vector<int> roots_;
  std::exception_ptr pending_;
  // A root found beyond the output time by the step that crossed it.
  bool pending_root_ = false;
  double pending_t_ = 0.0;
  std::vector<int> pending_roots_;
};

}  // namespace stickslip
