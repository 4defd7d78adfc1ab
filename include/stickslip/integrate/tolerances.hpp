#pragma once
// The one rule that turns [solver] rtol into the absolute tolerances of every
// state component, so that rtol alone controls the error of every method.
//
// An absolute tolerance is rtol times the scale below which a component's
// value no longer matters. With fixed absolute tolerances (as before) the
// contacts' creep speeds, 1e-6–1e-5 m/s, were controlled at 1e-7 m/s whatever
// rtol said, so tightening rtol moved no slip: rtol 1e-8 and 1e-10 took the
// same steps on Fig. 10b's pair and put its slips 140 ns apart.
//
//   velocity      V = 0.1 × the slowest of the drive speed and the contacts'
//                 v* (the speed on which a contact's force changes; creep
//                 below it decides when a contact lets go);
//   displacement  U = 0.1 × the displacement one spring k1 takes to balance a
//                 site's full contact force (System::contact_displacement);
//   energies      k1 a · atol_u, the impulse k1 a · atol_u / c_l: the scale
//                 one displacement tolerance makes of them.
// atol_velocity = rtol V and atol_displacement = rtol U unless the case sets
// them. The energy audit's bound (run.cpp) uses the same tolerances.

#include <nlohmann/json.hpp>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

struct ToleranceScales {
  double velocity = 0.0;      // V [m/s]
  double displacement = 0.0;  // U [m]
};
ToleranceScales tolerance_scales(const System& system);

// The solver parameters with atol_displacement and atol_velocity filled in
// by the rule where the case left them 0 (unset). A run resolves them once
// (resolve_solver, make_integrator.hpp) and hands the result down.
SolverParams with_absolute_tolerances(const System& system, SolverParams solver);

// Absolute tolerance of every state component (System's layout), spread from
// resolved parameters (with_absolute_tolerances): this applies no rule.
std::vector<double> absolute_tolerances(const System& system, const SolverParams& resolved);

// For summary.json: rtol, both absolute tolerances (`resolved`'s), the
// scales, and where each came from (given by the case, `given`, or the rule).
nlohmann::json describe_tolerances(const System& system, const SolverParams& given,
                                   const SolverParams& resolved);

}  // namespace stickslip
