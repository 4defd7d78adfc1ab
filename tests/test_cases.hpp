#pragma once
// Cases, systems and exact results more than one test file uses.
#include <cmath>
#include <span>

#include "stickslip/case/case.hpp"
#include "stickslip/case/placement.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip::test {

// The Fig. 10b pair (v* 4.75e-4 and 2.09e-3) on a 6×6×4 lattice.
inline Case two_contact_case() {
  Case c;
  c.lattice = {6, 6, 4, 1e-4};
  c.interface.contacts = {{1, 2, 4.75e-4, 0}, {4, 2, 2.09e-3, 0}};
  return c;
}

// The same pair as the sections of a case file, for tests that write one.
inline constexpr const char* kTwoContactToml = R"([lattice]
nx = 6
ny = 6
nz = 4
[interface]
contacts = [ { site = [1, 2], v_star = 4.75e-4 }, { site = [4, 2], v_star = 2.09e-3 } ]
)";

// 6×6×4 at the default coverage, 0.3 ms with rows every 1e-5 s: a run takes
// well under a second.
inline constexpr const char* kTinyBaseToml = R"([lattice]
nx = 6
ny = 6
nz = 4
[run]
t_end = 3e-4
average_from = 1e-4
[output]
interval = 1e-5
)";

// μ of steady sliding, every contact sliding at the drive speed v (MODEL.md
// §7): (τ_f/P0) mean φ(v/v*) + m η_c v / (ε P0 a²), with φ(r) = exp(−c
// (log10 r)²), η_c = η̂_c ω0 (§6), m = ρ a³ and ω0 = √(G1 + G2) / a from the
// material constants (§2), written out here rather than asked of System.
// `contacts`: the case's placed contacts, one per patch (every patch has R²
// sites, so the mean over patches is the mean over sites, §14).
inline double steady_sliding_mu_exact(const Case& c, std::span<const Contact> contacts) {
  const auto& i = c.interface;
  const double a = c.lattice.spacing, m = c.material.density * a * a * a;
  const double nu = c.material.poisson_ratio, e = c.material.youngs_modulus,
               rho = c.material.density;
  const double g1 = e / (2 * (1 + nu) * rho), g2 = (1 + 2 * nu) * g1;
  const double eta_c = c.damping.contact * std::sqrt(g1 + g2) / a;
  double mean_phi = 0.0;
  for (const auto& ct : contacts) {
    const double l = std::log10(c.drive.velocity / ct.v_star);
    mean_phi += std::exp(-i.shape * l * l) / static_cast<double>(contacts.size());
  }
  return i.shear_stress / i.max_pressure * mean_phi +
         m * eta_c * c.drive.velocity / (i.epsilon * i.max_pressure * a * a);
}

inline System make_system(const Case& c) {
  return System(c, place_contacts(c.lattice, c.interface));
}

}  // namespace stickslip::test
