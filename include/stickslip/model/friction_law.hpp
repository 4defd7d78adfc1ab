#pragma once
// The velocity dependence of a macro-asperity contact (MODEL.md §6):
//     φ(r) = exp(−c (log10 r)²),   r = |s| / v*,
// rising from 0 at rest to 1 at r = 1 (the top, |s| = v*) and falling beyond:
// the falling branch is what makes contacts stick and slip.

#include <array>
#include <cmath>
#include <numbers>

namespace stickslip {

struct FrictionLaw {
  double shape = 0.1;  // c

  // φ(r); φ(0) = 0, the limit, so the force is continuous at rest.
  double phi(double r) const {
    if (!(r > 0.0)) return 0.0;
    const double l = std::log10(r);
    return std::exp(-shape * l * l);
  }

  // φ'(r) = −2c log10(r) φ(r) / (r ln 10); tends to 0 at rest since φ decays
  // faster than any power of r.
  double dphi(double r) const { return phi_and_dphi(r)[1]; }

  // {φ(r), φ'(r)}, equal to phi(r) and dphi(r), from one logarithm and one
  // exponential: Newton on a contact's stage equation needs both every iteration.
  std::array<double, 2> phi_and_dphi(double r) const {
    if (!(r > 0.0)) return {0.0, 0.0};
    const double l = std::log10(r);
    const double phi = std::exp(-shape * l * l);
    return {phi, -2.0 * shape * l * phi / (r * std::numbers::ln10)};
  }
};

// In-plane contact force per unit mass, a = F_contact/m, with
//     F = −[ε f0 φ(|s|/v*) ŝ + m η_c s]                       (MODEL.md §6)
// `force_scale` is ε f0 / m [m/s²] and `eta_c` is η_c [1/s].
inline std::array<double, 2> contact_acceleration(const FrictionLaw& law, double force_scale,
                                                  double eta_c, double v_star, double sx,
                                                  double sy) {
  const double speed = std::hypot(sx, sy);
  // φ(r)/|s| → 0 as |s| → 0, so the φ term vanishes at rest (φ(0) ŝ := 0).
  const double phi_over_speed = speed > 0.0 ? law.phi(speed / v_star) / speed : 0.0;
  const double k = force_scale * phi_over_speed + eta_c;
  return {-k * sx, -k * sy};
}

// ∂a/∂s, the 2×2 block (row-major) of the contact's Jacobian:
//     ∂F/∂s = −ε f0 [φ'(r)/v* ŝŝᵀ + φ(r)/|s| (I − ŝŝᵀ)] − m η_c I,
// which is −m η_c I at rest.
inline std::array<double, 4> contact_jacobian(const FrictionLaw& law, double force_scale,
                                              double eta_c, double v_star, double sx, double sy) {
  const double speed = std::hypot(sx, sy);
  if (!(speed > 0.0)) return {-eta_c, 0.0, 0.0, -eta_c};
  const auto [phi, dphi] = law.phi_and_dphi(speed / v_star);
  const double radial = force_scale * dphi / v_star;    // along ŝ
  const double tangential = force_scale * phi / speed;  // across ŝ
  const double nx = sx / speed, ny = sy / speed;
  const double d = radial - tangential;
  return {-(tangential + d * nx * nx) - eta_c, -d * nx * ny, -d * ny * nx,
          -(tangential + d * ny * ny) - eta_c};
}

}  // namespace stickslip
