#pragma once
// The friction interface (MODEL.md §6, §9, §14): the contacts, their sites on
// the bottom layer, the law the case chose, and everything decided per site
// or per contact: forces and their Jacobian blocks, the exact stage solves,
// stick and slip, the rates the steppers guard with. System holds one and
// adds the lattice; it knows nothing of the lattice but where a site's
// velocity and displacement are in the state (layout: system.hpp).

#include <array>
#include <cstdint>
#include <span>
#include <variant>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/case/placement.hpp"
#include "stickslip/model/friction_law.hpp"

namespace stickslip {

// One bottom node carrying the contact law of MODEL.md §6. A contact's R×R
// patch (§14) is R² sites with the contact's speed scale (the law's
// speed_scale: v*); for R = 1 site j is contact j.
// The force law, its Jacobian and the implicit stage solves act on sites; stick,
// slip, events and traces on contacts (their sites' mean velocity).
struct FrictionSite {
  int ix = 0, iy = 0;
  std::int64_t node = 0;
  double v_star = 0.0;  // its contact's speed scale [m/s]
};

class ContactSet {
 public:
  // The contacts of a lattice of nx × ny × (nodes / (nx ny)) nodes, with the
  // law of `iface` (make_contact_law) at force scale ε f0/m [m/s²] and
  // contact damping η_c [1/s]; `mass` is a node's [kg]. Throws
  // std::invalid_argument for a patch or a contact that does not fit.
  ContactSet(const InterfaceParams& iface, std::vector<Contact> contacts, int nx, int ny,
             std::int64_t nodes, double mass, double force_scale, double eta_c);

  const std::vector<Contact>& contacts() const { return contacts_; }
  int patch() const { return patch_; }  // R
  const std::vector<FrictionSite>& sites() const { return sites_; }
  // Contact i's sites.
  std::span<const FrictionSite> sites_of(std::size_t i) const {
    const std::size_t per = std::size_t(patch_) * patch_;
    return std::span(sites_).subspan(i * per, per);
  }

  // Contact i's speed scale, the law's (v* for the paper's): the speed on
  // which its force changes [m/s].
  double speed_scale(std::size_t i) const;
  // The law's stick/slip root (MODEL.md §9) of contact i moving at `speed`
  // (|s_c|): positive while it slips (g = |s| − κ v* for the paper's).
  double stick_slip_root(std::size_t i, double speed) const;
  // g_k = stick_slip_root of each watched contact c = watched[k] at its
  // velocity in y.
  void stick_slip_roots(std::span<const double> y, std::span<const int> watched,
                        std::span<double> g) const;
  bool slipping(std::size_t i, std::span<const double> y) const;
  double slip_threshold() const { return slip_threshold_; }  // κ of §9

  // a_c of §6 (force per mass) of site j at in-plane velocity s.
  std::array<double, 2> site_acceleration(std::size_t j, std::array<double, 2> s) const;
  // ∂a/∂s of site j (2×2, row-major) at its velocity in y.
  std::array<double, 4> site_block(std::size_t j, std::span<const double> y) const;
  // Site j's stage equation s − γ a_c(s) = b, solved exactly by the law (its
  // `stage`, model/friction_law.hpp) as solve_implicit_stage does for every
  // site; `predictor_speed` picks among several roots. ∂s/∂b is bounded
  // (‖∂s/∂b‖ ≤ 1 where the force rises with speed) even where a_c's own
  // derivative reaches 1e15 s⁻¹, which is what makes it the variable a
  // coupled stage solve can run Newton on.
  ContactStage site_stage(std::size_t j, double gamma, std::array<double, 2> b,
                          double predictor_speed, bool derivative) const;
  // Solves the implicit stage equation of IMEX methods, z − γ f_implicit(z) = b,
  // exactly. f_implicit touches only the contacts' in-plane velocities, each
  // depending on its own, so every other component is z = b and each site
  // is a scalar equation for its speed (the law's stage). z (the whole
  // state) holds b on entry and the solution on return, so only the sites'
  // entries are touched: the caller forms b in place, one pass over the
  // state. The predictor picks among several roots. Returns the number of
  // scalar Newton iterations; throws StageNotConverged if one gives a speed
  // that is not finite. Per site: a patch's sites are independent here
  // (their coupling is the lattice's, explicit in imex).
  long solve_implicit_stage(double gamma, std::span<const double> predictor,
                            std::span<double> z) const;
  // ydot's sites' in-plane accelerations += a_c at their velocities in y.
  void add_accelerations(std::span<const double> y, std::span<double> ydot) const;
  // Each site's 2×2 block added at `slot` (SparseJacobian::contact_slot) of `value`.
  void add_jacobian_blocks(std::span<const double> y,
                           const std::vector<std::array<std::int64_t, 4>>& slot,
                           std::vector<double>& value) const;

  // The contacts' share of D (§8): ε f0 φ |s| + m η_c |s|² summed [W].
  double dissipation(std::span<const double> y) const;
  // The x component of the total contact force Σ_c F_contact,c (§6) at the
  // contacts' velocities in y [N]. Where a contact sticks, its force changes
  // by ~1e15 m per m/s of speed, far below the velocity tolerance: from an
  // interpolated state it is noise. System::contact_impulse is not.
  double total_force_x(std::span<const double> y) const;
  // |F_contact| of contact i, the sum over its sites [N].
  double contact_force(std::size_t i, std::span<const double> y) const;
  // Contact i's in-plane velocity: the mean of its sites' (§14).
  std::array<double, 2> contact_velocity(std::size_t i, std::span<const double> y) const;
  // |s| of contact i, the speed its stick and slip are decided on (§9) [m/s].
  double contact_speed(std::size_t i, std::span<const double> y) const;
  // Contact i's in-plane displacement: the mean of its sites' (u_x, u_y) [m].
  std::array<double, 2> contact_displacement(std::size_t i, std::span<const double> y) const;
  // |F| of the in-plane force the block exerts on contact i: the springs and
  // dashpots on its sites' nodes (MODEL.md §3–5), summed over its sites (so
  // those between two of its sites cancel), from the lattice's accelerations
  // `acc` (3N values: System::lattice_accelerations at the state) [N]. The
  // load the contact's friction holds while it sticks; its own force is
  // contact_force.
  double contact_load(std::size_t i, std::span<const double> acc) const;

  // The fastest growth rate of a site on the weakening branch, λ = −d|a_c|/d|s|
  // where the contact force falls with speed (past v*), 0 if none is [1/s].
  // A step with h λ ≫ 1 lets an L-stable method damp a slip's growth, and the
  // error estimate, built from two damped answers, cannot see it (steps.csv).
  double weakening_rate(std::span<const double> y) const;
  // The same for site j alone, at in-plane velocity s [1/s].
  double site_weakening_rate(std::size_t j, std::array<double, 2> s) const;
  // How fast site j's own law damps a change of its velocity at s: the
  // smaller of −∂a/∂|s| along ŝ and −a's tangential slope; negative past
  // the peak (where it weakens) [1/s].
  double site_damping_rate(std::size_t j, std::array<double, 2> s) const;

  // The mean over contacts of φ when sliding steadily at `speed` (§7).
  double mean_steady_phi(double speed) const;

 private:
  // f(law) with the case's law as its own type: a loop over sites runs
  // inside f, so each site calls the law directly.
  template <class F>
  decltype(auto) with_law(F&& f) const {
    return std::visit(std::forward<F>(f), law_);
  }
  std::int64_t w_index(std::int64_t node) const { return 3 * nodes_ + 3 * node; }
  std::int64_t u_index(std::int64_t node) const { return 3 * node; }
  std::array<double, 2> site_velocity(std::size_t j, std::span<const double> y) const {
    const std::int64_t wx = w_index(sites_[j].node);
    return {y[wx], y[wx + 1]};
  }

  std::int64_t nodes_;
  double mass_;
  double slip_threshold_;  // κ
  ContactLaws law_;
  std::vector<Contact> contacts_;
  int patch_;                        // R
  std::vector<FrictionSite> sites_;  // contact i's are [i R², (i + 1) R²)
};

}  // namespace stickslip
