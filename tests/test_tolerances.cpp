// The tolerance rule (integrate/tolerances.hpp): the absolute tolerances are
// rtol times scales computed here independently from the case's parameters.
#include <catch2/catch.hpp>
#include <cmath>

#include "stickslip/integrate/tolerances.hpp"
#include "test_cases.hpp"

using namespace stickslip;

namespace {

using test::make_system;

// k1 = m G1 / a² with m = ρ a³ and G1 = E / (2 (1 + ν) ρ) (MODEL.md §2).
double spring(const Case& c) {
  const double a = c.lattice.spacing;
  return c.material.youngs_modulus * a / (2 * (1 + c.material.poisson_ratio));
}

double site_force(const Case& c) {  // ε f0 = ε τ_f a² (MODEL.md §6)
  return c.interface.epsilon * c.interface.shear_stress * c.lattice.spacing * c.lattice.spacing;
}

}  // namespace

TEST_CASE("the tolerance scales come from the drive, the contacts and the springs",
          "[tolerances]") {
  Case c = test::two_contact_case();
  const ToleranceScales s = tolerance_scales(make_system(c));
  // The slower contact (4.75e-4) is slower than the drive (1e-3).
  CHECK(s.velocity == Approx(0.1 * 4.75e-4).epsilon(1e-12));
  CHECK(s.displacement == Approx(0.1 * site_force(c) / spring(c)).epsilon(1e-12));
  // The paper's parameters: 1.95e-7 m.
  CHECK(s.displacement == Approx(1.95e-7).epsilon(1e-9));

  c.drive.velocity = 1e-6;  // slower than every v*: the drive sets the scale
  CHECK(tolerance_scales(make_system(c)).velocity == Approx(1e-7).epsilon(1e-12));

  c.interface.epsilon = 0.0;  // no contact force: the drive over a cell's sound crossing
  const double nu = c.material.poisson_ratio;
  const double g1 = c.material.youngs_modulus / (2 * (1 + nu) * c.material.density);
  const double c_l = std::sqrt(g1 + (1 + 2 * nu) * g1);  // G2 = (1 + 2ν) G1 (paper)
  CHECK(tolerance_scales(make_system(c)).displacement ==
        Approx(0.1 * 1e-6 * c.lattice.spacing / c_l).epsilon(1e-12));
}

TEST_CASE("every absolute tolerance is proportional to rtol unless given", "[tolerances]") {
  Case c = test::two_contact_case();
  const System system = make_system(c);
  const std::int64_t n = system.num_nodes();
  SolverParams loose = c.solver, tight = c.solver;
  loose.rtol = 1e-5;
  tight.rtol = 1e-9;
  const auto a = absolute_tolerances(system, with_absolute_tolerances(system, loose)),
             b = absolute_tolerances(system, with_absolute_tolerances(system, tight));
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) CHECK(a[i] / b[i] == Approx(1e4).epsilon(1e-12));
  const ToleranceScales s = tolerance_scales(system);
  CHECK(a[0] == Approx(1e-5 * s.displacement).epsilon(1e-12));
  CHECK(a[3 * n] == Approx(1e-5 * s.velocity).epsilon(1e-12));
  // Energies: one displacement tolerance against one spring, k1 a atol_u.
  CHECK(a[system.quadrature_index(System::work_in)] ==
        Approx(spring(c) * c.lattice.spacing * 1e-5 * s.displacement).epsilon(1e-12));

  SolverParams given = loose;
  given.atol_velocity = 3e-9;
  const SolverParams resolved = with_absolute_tolerances(system, given);
  const auto g = absolute_tolerances(system, resolved);
  CHECK(g[3 * n] == 3e-9);
  CHECK(g[0] == a[0]);  // the other still follows rtol
  const auto d = describe_tolerances(system, given, resolved);
  CHECK(d["atol_velocity_from"] == "given");
  CHECK(d["atol_displacement"] == Approx(1e-5 * s.displacement).epsilon(1e-12));
}
