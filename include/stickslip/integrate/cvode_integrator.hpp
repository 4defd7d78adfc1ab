#pragma once
// CVODE adapter for bdf: variable-order BDF, its corrector solved exactly
// (LatticeStageSolver).

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
  double current_time() const override;
  long steps_taken() const override;
  double last_step_size() const override;
  void set_max_steps(long steps) override;
  int evolve(double t_out, double* t, bool one_step) override;
  void root_info(int* roots) override;
  void interpolate(double t, N_Vector y) override;
  bool local_errors(N_Vector error, N_Vector weights) const override;
  const char* evolve_name() const override;
  std::string flag_name(int flag) const override;

  int max_order_;
  CvodeMemPtr cvode_mem_;  // after what it refers to, so freed before it
};

}  // namespace stickslip
