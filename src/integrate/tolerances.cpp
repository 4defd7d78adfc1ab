#include "stickslip/integrate/tolerances.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace stickslip {
namespace {

// Fractions of the physical scales at which a component stops mattering.
// Measured (docs/notes/performance-history.md, "Tolerances that follow rtol"): with these,
// the slip times of the pairs converge in proportion to rtol for every method.
constexpr double kVelocityFraction = 0.1;
constexpr double kDisplacementFraction = 0.1;
// A lattice with neither drive nor contacts has no speed of its own; this is
// the paper's drive speed.
constexpr double kFallbackSpeed = 1e-3;  // [m/s]

}  // namespace

ToleranceScales tolerance_scales(const System& system) {
  double speed = std::numeric_limits<double>::infinity();
  if (system.drive_velocity() > 0) speed = system.drive_velocity();
  // The smallest of the contacts' speed scales: their law's.
  for (std::size_t i = 0; i < system.contact_set().contacts().size(); ++i)
    speed = std::min(speed, system.contact_set().speed_scale(i));
  if (!std::isfinite(speed)) speed = kFallbackSpeed;
  // Without contact forces (ε = 0) the lattice's own scale: the drive's
  // displacement over the time sound takes to cross one cell.
  double displacement = system.contact_displacement();
  if (!(displacement > 0)) displacement = speed * system.spacing() / system.longitudinal_speed();
  return {kVelocityFraction * speed, kDisplacementFraction * displacement};
}

SolverParams with_absolute_tolerances(const System& system, SolverParams solver) {
  const ToleranceScales scale = tolerance_scales(system);
  if (!(solver.atol_velocity > 0)) solver.atol_velocity = solver.rtol * scale.velocity;
  if (!(solver.atol_displacement > 0)) solver.atol_displacement = solver.rtol * scale.displacement;
  return solver;
}

std::vector<double> absolute_tolerances(const System& system, const SolverParams& solver) {
  const std::int64_t n = system.num_nodes();
  std::vector<double> atol(static_cast<std::size_t>(system.size()));
  std::fill(atol.begin(), atol.begin() + 3 * n, solver.atol_displacement);
  std::fill(atol.begin() + 3 * n, atol.begin() + 6 * n, solver.atol_velocity);
  const double k1 = system.k1();
  const double energy = k1 * system.spacing() * solver.atol_displacement;
  const double c_l = system.longitudinal_speed();
  atol[system.quadrature_index(System::work_in)] = energy;
  atol[system.quadrature_index(System::dissipated)] = energy;
  atol[system.quadrature_index(System::friction_impulse)] =
      k1 * solver.atol_displacement * system.spacing() / c_l;
  return atol;
}

nlohmann::json describe_tolerances(const System& system, const SolverParams& given,
                                   const SolverParams& solver) {
  const ToleranceScales scale = tolerance_scales(system);
  auto origin = [&](double set, const char* rule) {
    return set > 0 ? std::string("given") : std::string(rule);
  };
  return {{"rtol", solver.rtol},
          {"atol_velocity", solver.atol_velocity},
          {"atol_displacement", solver.atol_displacement},
          {"velocity_scale", scale.velocity},
          {"displacement_scale", scale.displacement},
          {"atol_velocity_from",
           origin(given.atol_velocity, "rtol x 0.1 x min(drive speed, smallest v*)")},
          {"atol_displacement_from",
           origin(given.atol_displacement, "rtol x 0.1 x a site's full contact force / k1")}};
}

}  // namespace stickslip
