#pragma once
// Which integrator a case runs, and making it: the factory apart from the
// interface (integrator.hpp), as Cantera keeps newIntegrator apart from
// Integrator, so the adapters, which implement the interface, are included
// only here.

#include <memory>
#include <span>
#include <string>

#include "stickslip/case/case.hpp"
#include "stickslip/integrate/integrator.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

// The method "auto" runs, and why (summary.json says both). The rule follows
// the work-precision benchmarks at equal accuracy against converged runs
// (docs/PERFORMANCE.md): where no contact can stick-slip at the drive speed
// (every v* ≥ v: steady sliding, creep) bdf wins by 40–100×, its steps
// growing to ~1e-4 s; where some can, dirk: once the absolute tolerances
// follow rtol (tolerances.hpp) its slips are as accurate as imex's, whose
// steps the explicit lattice holds below ~2e-7 s and the creep far below.
// (dirk's late slips of earlier measurements were the fixed velocity
// tolerance of 1e-7 m/s.) A fixed step keeps imex.
struct MethodChoice {
  Method method;
  std::string reason;
};
MethodChoice choose_method(const System& system, const SolverParams& solver);

// The energy-audit bound of a fixed-step run, which has no rtol: the
// default tolerances' bound, 100 × 1e-6.
inline constexpr double kFixedStepAuditBound = 1e-4;

// A case's [solver] as it is integrated: what its rules leave open decided
// once, here, and handed down, so no part of a run applies a rule again.
struct ResolvedSolver {
  SolverParams given;     // the case's own: what summary.json says was given
  SolverParams params;    // a method, never "auto"; atol_* by the rule where not given;
                          // threads resolved (resolved_threads): the run's budget
  std::string chosen_by;  // why "auto" chose params.method; empty if the case named it
  // The largest |energy-audit residual| at t_end a result may have:
  // [solver] audit_bound, else 100 × rtol (sound runs show 0.01–10 × rtol,
  // docs/STABILITY.md), or kFixedStepAuditBound for a fixed step.
  double audit_bound = 0.0;
};
ResolvedSolver resolve_solver(const System& system, const SolverParams& given);

// Starts from y0 at t0 (0 for a run; later for a restart or a test).
std::unique_ptr<Integrator> make_integrator(const System& system, const ResolvedSolver& solver,
                                            std::span<const double> y0, double t_stop,
                                            IntegratorOptions options, double t0 = 0.0);
// The same from the case's own parameters, resolved first.
std::unique_ptr<Integrator> make_integrator(const System& system, const SolverParams& solver,
                                            std::span<const double> y0, double t_stop,
                                            IntegratorOptions options, double t0 = 0.0);

// summary.json's `solver` object, written here alone: the integrator's own
// description (its method, package call and table), how its implicit part is
// solved, the fixed step or the tolerances and where they came from, why
// "auto" chose the method, and the threads.
nlohmann::json describe_solver(const System& system, const ResolvedSolver& solver,
                               const Integrator& integrator);

// The columns a resolved method's stepper adds to steps.csv (its own
// StepRecord::method_values); none for SUNDIALS' packages.
std::span<const StepColumn> step_columns(Method m);

}  // namespace stickslip
