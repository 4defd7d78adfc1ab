// The contact law of MODEL.md §6 and its derivatives.
#include <catch2/catch.hpp>
#include <cmath>

#include "stickslip/model/friction_law.hpp"

using namespace stickslip;

TEST_CASE("phi peaks at r = 1, is symmetric in log r and vanishes at rest", "[friction]") {
  const FrictionLaw law{0.1};
  CHECK(law.phi(1.0) == 1.0);
  CHECK(law.phi(10.0) == Approx(std::exp(-0.1)).epsilon(1e-15));
  for (double r : {1e-6, 3e-2, 0.5, 2.0, 77.0})
    CHECK(law.phi(r) == Approx(law.phi(1.0 / r)).epsilon(1e-13));
  CHECK(law.phi(0.0) == 0.0);
  CHECK(law.dphi(1.0) == 0.0);
  CHECK(law.dphi(0.5) > 0.0);
  CHECK(law.dphi(2.0) < 0.0);
}

TEST_CASE("dphi matches a central difference of phi", "[friction]") {
  const FrictionLaw law{0.1};
  for (double r : {1e-9, 1e-4, 0.3, 1.7, 40.0}) {
    const double h = 1e-6 * r;
    const double fd = (law.phi(r + h) - law.phi(r - h)) / (2 * h);
    CHECK(law.dphi(r) == Approx(fd).epsilon(1e-7));
  }
}

TEST_CASE("phi_and_dphi is phi and dphi, to the bit", "[friction]") {
  const FrictionLaw law{0.1};
  for (double r : {0.0, 1e-300, 1e-12, 0.3, 1.0, 1.7, 40.0, 1e8}) {
    const auto [phi, dphi] = law.phi_and_dphi(r);
    CHECK(phi == law.phi(r));
    CHECK(dphi == law.dphi(r));
  }
}

TEST_CASE("contact Jacobian block matches finite differences away from rest", "[friction]") {
  const FrictionLaw law{0.1};
  const double scale = 6.5e5, eta_c = 1e5, v_star = 1e-3;
  for (auto [sx, sy] : {std::pair{3e-4, 0.0}, {-2e-3, 1e-3}, {1e-5, -4e-6}, {0.0, 5e-2}}) {
    const auto J = contact_jacobian(law, scale, eta_c, v_star, sx, sy);
    const double s[2] = {sx, sy};
    for (int c = 0; c < 2; ++c) {
      const double h = 1e-7 * std::hypot(sx, sy);
      double p[2] = {s[0], s[1]}, m[2] = {s[0], s[1]};
      p[c] += h;
      m[c] -= h;
      const auto ap = contact_acceleration(law, scale, eta_c, v_star, p[0], p[1]);
      const auto am = contact_acceleration(law, scale, eta_c, v_star, m[0], m[1]);
      for (int r = 0; r < 2; ++r) {
        const double fd = (ap[r] - am[r]) / (2 * h);
        CHECK(J[2 * r + c] == Approx(fd).epsilon(1e-6).margin(1e-6 * std::abs(J[0])));
      }
    }
  }
}

TEST_CASE("contact force opposes motion and is pure damping at rest", "[friction]") {
  const FrictionLaw law{0.1};
  const auto J = contact_jacobian(law, 6.5e5, 1e5, 1e-3, 0.0, 0.0);
  CHECK(J[0] == -1e5);
  CHECK(J[1] == 0.0);
  CHECK(J[2] == 0.0);
  CHECK(J[3] == -1e5);
  const auto a = contact_acceleration(law, 6.5e5, 1e5, 1e-3, 3e-3, -4e-3);
  CHECK(a[0] * 3e-3 + a[1] * -4e-3 < 0.0);
  CHECK(a[0] / 3e-3 == Approx(a[1] / -4e-3));  // antiparallel to s
  // |a| = scale φ(|s|/v*) + η_c |s|.
  CHECK(std::hypot(a[0], a[1]) == Approx(6.5e5 * law.phi(5.0) + 1e5 * 5e-3));
}
