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
  int max_order_;
};

}  // namespace stickslip
