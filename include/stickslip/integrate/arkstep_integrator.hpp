#pragma once
// ARKStep adapter for imex, dirk, erk and rk4 (adaptive or fixed step).

#include "stickslip/integrate/stepping_integrator.hpp"
#include "stickslip/integrate/sundials.hpp"

namespace stickslip {

class ArkStepIntegrator final : public SteppingIntegrator {
 public:
  ArkStepIntegrator(const System& system, const SolverParams& solver, std::span<const double> y0,
                    double t0, double t_stop, IntegratorOptions options);
  ArkStepIntegrator(const ArkStepIntegrator&) = delete;
  ArkStepIntegrator& operator=(const ArkStepIntegrator&) = delete;

  SolverStats stats() const override;
  nlohmann::json description() const override;
};

}  // namespace stickslip
