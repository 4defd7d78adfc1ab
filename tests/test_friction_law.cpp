// The contact law of MODEL.md §6 and §9 (model/friction_law.hpp): φ and its
// derivative, the force and its Jacobian, the stick/slip root, the speed
// scale and the exact stage solve, each against an exact value or a finite
// difference.
#include <catch2/catch.hpp>
#include <cmath>

#include "stickslip/model/friction_law.hpp"

using namespace stickslip;

namespace {

// c = 0.1, κ = 2, S = ε f0/m = 6.5e5 m/s², η_c = 1e5 /s.
PaperLaw law_of(double shape = 0.1, double kappa = 2.0, double scale = 6.5e5, double eta_c = 1e5) {
  return PaperLaw{{shape}, kappa, scale, eta_c};
}

}  // namespace

TEST_CASE("phi peaks at r = 1, is symmetric in log r and vanishes at rest", "[friction]") {
  const PaperLaw law = law_of();
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
  const PaperLaw law = law_of();
  for (double r : {1e-9, 1e-4, 0.3, 1.7, 40.0}) {
    const double h = 1e-6 * r;
    const double fd = (law.phi(r + h) - law.phi(r - h)) / (2 * h);
    CHECK(law.dphi(r) == Approx(fd).epsilon(1e-7));
  }
}

TEST_CASE("phi_and_dphi is phi and dphi, to the bit", "[friction]") {
  const PaperLaw law = law_of();
  for (double r : {0.0, 1e-300, 1e-12, 0.3, 1.0, 1.7, 40.0, 1e8}) {
    const auto [phi, dphi] = law.phi_and_dphi(r);
    CHECK(phi == law.phi(r));
    CHECK(dphi == law.dphi(r));
  }
}

TEST_CASE("contact Jacobian block matches finite differences away from rest", "[friction]") {
  const PaperLaw law = law_of();
  const double v_star = 1e-3;
  for (auto [sx, sy] : {std::pair{3e-4, 0.0}, {-2e-3, 1e-3}, {1e-5, -4e-6}, {0.0, 5e-2}}) {
    const auto J = law.jacobian(v_star, {sx, sy});
    const double s[2] = {sx, sy};
    for (int c = 0; c < 2; ++c) {
      const double h = 1e-7 * std::hypot(sx, sy);
      std::array<double, 2> p = {s[0], s[1]}, m = {s[0], s[1]};
      p[c] += h;
      m[c] -= h;
      const auto ap = law.acceleration(v_star, p);
      const auto am = law.acceleration(v_star, m);
      for (int r = 0; r < 2; ++r) {
        const double fd = (ap[r] - am[r]) / (2 * h);
        CHECK(J[2 * r + c] == Approx(fd).epsilon(1e-6).margin(1e-6 * std::abs(J[0])));
      }
    }
  }
}

TEST_CASE("contact force opposes motion and is pure damping at rest", "[friction]") {
  const PaperLaw law = law_of();
  const auto J = law.jacobian(1e-3, {0.0, 0.0});
  CHECK(J[0] == -1e5);
  CHECK(J[1] == 0.0);
  CHECK(J[2] == 0.0);
  CHECK(J[3] == -1e5);
  const auto a = law.acceleration(1e-3, {3e-3, -4e-3});
  CHECK(a[0] * 3e-3 + a[1] * -4e-3 < 0.0);
  CHECK(a[0] / 3e-3 == Approx(a[1] / -4e-3));  // antiparallel to s
  // |a| = scale φ(|s|/v*) + η_c |s|.
  CHECK(std::hypot(a[0], a[1]) == Approx(6.5e5 * law.phi(5.0) + 1e5 * 5e-3));
  CHECK(law.acceleration(1e-3, {0.0, 0.0}) == std::array{0.0, 0.0});
}

TEST_CASE("the law's speed scale is v*, its root |s| - kappa v*, and it slips past the root",
          "[friction]") {
  const PaperLaw law = law_of(0.1, 2.0);
  const Contact contact{3, 4, 4.75e-4};
  CHECK(law.speed_scale(contact) == 4.75e-4);
  const double v_star = law.speed_scale(contact);
  // κ v* = 9.5e-4: the root's zero, negative below, positive above, slope 1.
  CHECK(law.stick_slip_root(9.5e-4, v_star) == Approx(0.0).margin(1e-19));
  CHECK(law.stick_slip_root(0.0, v_star) == Approx(-9.5e-4).epsilon(1e-15));
  CHECK(law.stick_slip_root(3e-3, v_star) == Approx(3e-3 - 9.5e-4).epsilon(1e-15));
  const double h = 1e-9;
  CHECK((law.stick_slip_root(2e-3 + h, v_star) - law.stick_slip_root(2e-3 - h, v_star)) / (2 * h) ==
        Approx(1.0).epsilon(1e-6));
  CHECK_FALSE(law.slips(9e-4, v_star));
  CHECK(law.slips(1e-3, v_star));
  for (double speed : {0.0, 1e-5, 9.4e-4, 9.6e-4, 1.0})
    CHECK(law.slips(speed, v_star) == (law.stick_slip_root(speed, v_star) > 0.0));
  // Steady sliding at v: φ(v/v*).
  CHECK(law.steady_phi(1e-3, v_star) == law.phi(1e-3 / v_star));
  CHECK(law.steady_phi(v_star, v_star) == 1.0);
}

TEST_CASE("the law's stage solve satisfies s - gamma a(s) = b with the derivative it reports",
          "[friction]") {
  const PaperLaw law = law_of();
  const double v_star = 1e-3, gamma = 1e-6;
  for (auto b : {std::array{3e-4, 0.0}, {-2e-3, 1e-3}, {1e-7, -4e-8}, {0.0, 5e-2}}) {
    INFO("b = (" << b[0] << ", " << b[1] << ")");
    const ContactStage st = law.stage(v_star, gamma, b, std::hypot(b[0], b[1]), true);
    const auto a = law.acceleration(v_star, st.s);
    for (int k = 0; k < 2; ++k)
      CHECK(st.s[k] - gamma * a[k] == Approx(b[k]).epsilon(1e-12).margin(1e-18));
    // ∂s/∂b against a central difference of the solve itself.
    for (int c = 0; c < 2; ++c) {
      const double h = 1e-6 * std::hypot(b[0], b[1]);
      auto p = b, m = b;
      p[c] += h;
      m[c] -= h;
      const auto sp = law.stage(v_star, gamma, p, std::hypot(p[0], p[1]), false).s;
      const auto sm = law.stage(v_star, gamma, m, std::hypot(m[0], m[1]), false).s;
      for (int r = 0; r < 2; ++r)
        CHECK(st.ds_db[2 * r + c] == Approx((sp[r] - sm[r]) / (2 * h)).epsilon(1e-5).margin(1e-9));
    }
  }
  // b = 0: s = 0 and ∂s/∂b = I/(1 + γ η_c).
  const ContactStage rest = law.stage(v_star, gamma, {0.0, 0.0}, 0.0, true);
  CHECK(rest.s == std::array{0.0, 0.0});
  CHECK(rest.ds_db[0] == Approx(1.0 / (1.0 + gamma * 1e5)));
  CHECK(rest.ds_db[1] == 0.0);
}

TEST_CASE("the case's law is the paper's, with the case's and the system's parameters",
          "[friction]") {
  InterfaceParams iface;
  iface.shape = 0.25;
  iface.slip_threshold = 1.5;
  const ContactLaws chosen = make_contact_law(iface, 7e5, 3e4);
  REQUIRE(std::holds_alternative<PaperLaw>(chosen));
  const PaperLaw& law = std::get<PaperLaw>(chosen);
  CHECK(law.shape == 0.25);
  CHECK(law.slip_threshold == 1.5);
  CHECK(law.force_scale == 7e5);
  CHECK(law.eta_c == 3e4);
  CHECK(law.phi(10.0) == Approx(std::exp(-0.25)).epsilon(1e-15));
}
