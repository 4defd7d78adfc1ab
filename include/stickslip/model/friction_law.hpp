#pragma once
// Contact laws: everything about how a friction site resists sliding
// (MODEL.md §6) and when its contact counts as slipping (§9), in one type per
// law. The forces, the Jacobian's contact blocks, the exact stage solves, the
// stick/slip roots, the tolerances' speed scale, the method `auto` picks and
// steady sliding's μ all ask the law; none re-derives it from v*.
//
// A law is a policy class (tandem's RateAndState<Law> is the shape): System
// holds the one the case chose ([interface] law) by value, in ContactLaws, and
// its loops over sites call it directly (one std::visit per loop, no virtual
// call per site).
//
// The paper's law is one of a family, F = −[ε f0 φ(|s|/v*) ŝ + m η_c s] for
// a velocity dependence φ(r) of r = |s|/v*: SpeedLaw<Shape> below is all of
// the family but φ, which Shape gives. Adding a law of this shape is its
// Shape (φ and φ'), its line in ContactLaws and make_contact_law, and its
// name in ContactLawName (case/case.hpp) and the `law` row of the reader's
// schema (src/case/reader.cpp): docs/DEVELOPERS.md, "Adding to it".

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <numbers>
#include <stdexcept>
#include <variant>

#include "stickslip/case/case.hpp"
#include "stickslip/case/placement.hpp"

namespace stickslip {

// One site's implicit stage equation s − γ a_c(s) = b solved exactly
// (a_c: its in-plane acceleration, MODEL.md §6), with ∂s/∂b when asked for.
struct ContactStage {
  std::array<double, 2> s{};
  std::array<double, 4> ds_db{};  // row-major; filled only when asked for
  long iterations = 0;            // scalar Newton iterations
};

// A stage solve that did not converge (a step too large for the contacts'
// stage equations): the integrator may retry with a smaller step. Any other
// exception from a stage solve is a bug and stops the run with its message.
struct StageNotConverged : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// What every user asks of a law. `scale` is a contact's speed scale
// (speed_scale; v* for the paper's law), which its sites share; s a site's
// in-plane velocity [m/s]; accelerations are forces per site mass [m/s²].
template <class L>
concept ContactLaw = requires(const L& law, const Contact& contact, double r, double speed,
                              double scale, double gamma, std::array<double, 2> s,
                              bool derivative) {
  // φ(r) and {φ(r), φ'(r)}: the force's dependence on the relative speed r.
  { law.phi(r) } -> std::same_as<double>;
  { law.phi_and_dphi(r) } -> std::same_as<std::array<double, 2>>;
  // The speed on which the contact's force changes [m/s]: the tolerances'
  // velocity scale, and `auto`'s test for contacts that stick-slip at the
  // drive speed (those whose scale is below it).
  { law.speed_scale(contact) } -> std::same_as<double>;
  // The stick/slip root g of a contact moving at `speed`: positive while it
  // slips (MODEL.md §9), and whether it slips (g > 0).
  { law.stick_slip_root(speed, scale) } -> std::same_as<double>;
  { law.slips(speed, scale) } -> std::same_as<bool>;
  // a_c(s) and ∂a_c/∂s (2×2, row-major).
  { law.acceleration(scale, s) } -> std::same_as<std::array<double, 2>>;
  { law.jacobian(scale, s) } -> std::same_as<std::array<double, 4>>;
  // The stage solve's contract: s − γ a_c(s) = b solved exactly for b = s,
  // choosing among several roots the one on the side of `speed` (the
  // predictor's), with ∂s/∂b if `derivative`; bounded ∂s/∂b is what the
  // coupled stage solves run Newton on. Throws StageNotConverged.
  { law.stage(scale, gamma, s, speed, derivative) } -> std::same_as<ContactStage>;
  // φ of a contact sliding steadily at `speed` (MODEL.md §7's exact μ).
  { law.steady_phi(speed, scale) } -> std::same_as<double>;
};

// The paper's velocity dependence (MODEL.md §6):
//     φ(r) = exp(−c (log10 r)²),   r = |s| / v*,
// rising from 0 at rest to 1 at r = 1 (the top, |s| = v*) and falling beyond:
// the falling branch is what makes contacts stick and slip.
struct PaperShape {
  double shape = 0.1;  // c

  // φ(r); φ(0) = 0, the limit, so the force is continuous at rest.
  double phi(double r) const {
    if (!(r > 0.0)) return 0.0;
    const double l = std::log10(r);
    return std::exp(-shape * l * l);
  }

  // {φ(r), φ'(r)}, φ'(r) = −2c log10(r) φ(r) / (r ln 10), from one logarithm
  // and one exponential: Newton on a contact's stage equation needs both
  // every iteration. φ' tends to 0 at rest since φ decays faster than any
  // power of r.
  std::array<double, 2> phi_and_dphi(double r) const {
    if (!(r > 0.0)) return {0.0, 0.0};
    const double l = std::log10(r);
    const double phi = std::exp(-shape * l * l);
    return {phi, -2.0 * shape * l * phi / (r * std::numbers::ln10)};
  }
};

// F = −[ε f0 φ(|s|/v*) ŝ + m η_c s] (MODEL.md §6) for the φ of Shape, which
// must rise from φ(0) = 0 and be bounded: the stage solve's bracket assumes
// it (a law that does not brings a stage of its own). A contact slips while
// |s| > κ v* (§9).
template <class Shape>
struct SpeedLaw : Shape {
  double slip_threshold = 1.0;  // κ
  double force_scale = 0.0;     // ε f0 / m [m/s²]
  double eta_c = 0.0;           // η_c [1/s]

  using Shape::phi;
  using Shape::phi_and_dphi;
  double dphi(double r) const { return phi_and_dphi(r)[1]; }

  double speed_scale(const Contact& contact) const { return contact.v_star; }
  // g = |s| − κ v*.
  double stick_slip_root(double speed, double v_star) const {
    return speed - slip_threshold * v_star;
  }
  bool slips(double speed, double v_star) const { return speed > slip_threshold * v_star; }
  double steady_phi(double speed, double v_star) const { return phi(speed / v_star); }

  // a = F/m = −[S φ(|s|/v*) ŝ + η_c s], S = ε f0/m.
  std::array<double, 2> acceleration(double v_star, std::array<double, 2> s) const {
    const double speed = std::hypot(s[0], s[1]);
    // φ(r)/|s| → 0 as |s| → 0, so the φ term vanishes at rest (φ(0) ŝ := 0).
    const double phi_over_speed = speed > 0.0 ? phi(speed / v_star) / speed : 0.0;
    const double k = force_scale * phi_over_speed + eta_c;
    return {-k * s[0], -k * s[1]};
  }

  // ∂a/∂s, the 2×2 block (row-major) of the contact's Jacobian:
  //     ∂F/∂s = −ε f0 [φ'(r)/v* ŝŝᵀ + φ(r)/|s| (I − ŝŝᵀ)] − m η_c I,
  // which is −m η_c I at rest.
  std::array<double, 4> jacobian(double v_star, std::array<double, 2> s) const {
    const double speed = std::hypot(s[0], s[1]);
    if (!(speed > 0.0)) return {-eta_c, 0.0, 0.0, -eta_c};
    const auto [phi, dphi] = phi_and_dphi(speed / v_star);
    const double radial = force_scale * dphi / v_star;    // along ŝ
    const double tangential = force_scale * phi / speed;  // across ŝ
    const double nx = s[0] / speed, ny = s[1] / speed;
    const double d = radial - tangential;
    return {-(tangential + d * nx * nx) - eta_c, -d * nx * ny, -d * ny * nx,
            -(tangential + d * ny * ny) - eta_c};
  }

  // s + γ k(|s|) s = b with k(λ) = S φ(λ/v*)/λ + η_c ≥ 0 (S = ε f0/m),
  // so s is parallel to b and its length λ solves
  //     g(λ) = λ (1 + γ η_c) + γ S φ(λ/v*) − |b| = 0,   0 ≤ λ ≤ |b|/(1 + γ η_c),
  // where g starts negative and ends non-negative. On the velocity-weakening
  // branch (λ > v*) g need not be monotone; the bracket is then chosen on the
  // side of the predictor's speed so the root found continues the trajectory.
  // Newton runs in x = ln λ, where φ is a Gaussian and well-behaved across the
  // 10¹⁰–10¹⁵ s⁻¹ stiffness near rest that defeats Newton in λ (MODEL.md §12),
  // safeguarded by bisection of the bracket.
  //
  // ∂s/∂b: radially dλ/d|b| = 1/g'(λ), tangentially λ/|b| (s stays parallel
  // to b), so ∂s/∂b = (1/g') b̂b̂ᵀ + (λ/|b|)(I − b̂b̂ᵀ); at b = 0 it is I/(1 + γ η_c)
  // (φ(r)/r and φ'(r) vanish as r → 0).
  ContactStage stage(double v_star, double gamma, std::array<double, 2> b, double predictor_speed,
                     bool derivative) const {
    ContactStage out;
    const double damping = 1.0 + gamma * eta_c;
    const double gs = gamma * force_scale;
    const double bx = b[0], by = b[1];
    const double b_len = std::hypot(bx, by);
    auto pure_damping = [&] {
      out.s = {bx / damping, by / damping};
      if (derivative) out.ds_db = {1.0 / damping, 0.0, 0.0, 1.0 / damping};
      return out;
    };
    if (b_len == 0.0) return pure_damping();
    auto g = [&](double lambda) { return lambda * damping + gs * phi(lambda / v_star) - b_len; };
    auto dg = [&](double lambda) { return damping + gs * dphi(lambda / v_star) / v_star; };
    // g(λ) and dg/dx (x = ln λ), sharing one evaluation of φ.
    auto g_and_slope = [&](double lambda) {
      const auto [p, dp] = phi_and_dphi(lambda / v_star);
      return std::array{lambda * damping + gs * p - b_len, lambda * (damping + gs * dp / v_star)};
    };

    double hi = b_len / damping;
    // Below this speed φ is under 1e-300: the force is pure damping.
    double lo = v_star * 1e-40;
    if (hi <= lo || g(lo) >= 0.0) return pure_damping();
    // Newton starts from the predictor's speed, which is near the root when the
    // step is small (b itself when gamma is small); its first iteration puts the
    // predictor at one end of the bracket, so the root found is on the
    // predictor's side. A predictor outside the bracket says nothing: start in
    // its middle.
    double lambda = std::clamp(predictor_speed, lo, hi);
    if (!(lambda > lo && lambda < hi)) lambda = std::sqrt(lo * hi);
    bool converged = false;
    for (int it = 0; it < 200 && !converged; ++it) {
      ++out.iterations;
      const auto [gl, slope] = g_and_slope(lambda);
      if (gl == 0.0) break;
      (gl < 0.0 ? lo : hi) = lambda;
      double next = slope > 0.0 ? lambda * std::exp(-gl / slope) : 0.0;
      if (!(next > lo && next < hi)) next = std::sqrt(lo * hi);  // bisect in x
      converged = std::abs(next - lambda) <= 1e-15 * lambda || hi - lo <= 1e-15 * hi;
      lambda = next;
    }
    if (!std::isfinite(lambda))
      throw StageNotConverged("contact stage solve produced a non-finite speed");
    const double scale = lambda / b_len;
    out.s = {bx * scale, by * scale};
    if (derivative) {
      const double radial = 1.0 / dg(lambda);
      const double ux = bx / b_len, uy = by / b_len;
      out.ds_db = {scale + (radial - scale) * ux * ux, (radial - scale) * ux * uy,
                   (radial - scale) * ux * uy, scale + (radial - scale) * uy * uy};
    }
    return out;
  }
};

// The paper's law (MODEL.md §6, §9).
using PaperLaw = SpeedLaw<PaperShape>;
static_assert(ContactLaw<PaperLaw>);

// The laws a case may choose, one alternative each, in ContactLawName's order.
using ContactLaws = std::variant<PaperLaw>;

// The case's law with its parameters: [interface]'s, and the force scale
// ε f0/m [m/s²] and contact damping η_c [1/s] that System derives.
inline ContactLaws make_contact_law(const InterfaceParams& iface, double force_scale,
                                    double eta_c) {
  switch (iface.law) {
    case ContactLawName::paper:
      return PaperLaw{{iface.shape}, iface.slip_threshold, force_scale, eta_c};
  }
  throw std::logic_error("make_contact_law: no law for the case's [interface] law");
}

}  // namespace stickslip
