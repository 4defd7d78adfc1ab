#pragma once
// ARKStep adapter: owns every SUNDIALS handle of an adaptive IMEX run of a
// System (contact forces implicit, lattice explicit).

#include <exception>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/integrate/contact_stage_solver.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

struct SolverStats {
  long steps = 0;
  long step_attempts = 0;
  long rhs_explicit = 0;
  long rhs_implicit = 0;
  long newton_iterations = 0;            // scalar Newton iterations of the stage solves
  long newton_convergence_failures = 0;  // steps retried because a stage solve failed
  long linear_setups = 0;
  long jacobian_evaluations = 0;
  long error_test_failures = 0;
  double last_step = 0.0;
};

// Absolute tolerance of every state component: displacements and velocities
// from the case; the quadratures of the energy audit and of μ get a scale that
// one displacement tolerance makes of them (k1 a · atol_u for energies,
// k1 · atol_u · a / c_l for the impulse), so they are controlled relatively.
std::vector<double> absolute_tolerances(const System& system, const SolverParams& solver);

class ArkodeIntegrator {
 public:
  ArkodeIntegrator(const System& system, const SolverParams& solver, std::span<const double> y0,
                   double t_stop);
  ~ArkodeIntegrator();
  ArkodeIntegrator(const ArkodeIntegrator&) = delete;
  ArkodeIntegrator& operator=(const ArkodeIntegrator&) = delete;

  // Integrates on to t_out and writes y(t_out) (interpolated between steps,
  // so output times never shape the step sequence) into y.
  void advance_to(double t_out, std::span<double> y);
  SolverStats stats() const;
  std::string method_name() const;

 private:
  static int explicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);
  static int implicit_rhs(double t, N_Vector y, N_Vector ydot, void* self);
  [[noreturn]] void fail(int flag, double t) const;

  const System& system_;
  SunContext ctx_;
  NVectorPtr y_;
  NVectorPtr atol_;
  ContactStageStats stage_stats_;
  NonlinearSolverPtr nonlinear_solver_;
  void* arkode_mem_ = nullptr;
  std::exception_ptr pending_;
  long max_steps_;
};

}  // namespace stickslip
