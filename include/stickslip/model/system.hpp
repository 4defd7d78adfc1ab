#pragma once
// The 3D spring-block model of MODEL.md §1–8 as an ODE system y' = f(t, y).
// It knows nothing of any integrator: it fills derivatives, Jacobian values
// and observables from plain arrays.
//
// State layout (size 6N + 3, N = Nx Ny Nz nodes, node n = ix + Nx (iy + Ny iz)):
//   y[3n + k]        displacement u_n^k          [m]
//   y[3N + 3n + k]   velocity w_n^k              [m/s]
//   y[6N + 0]        ∫ P_in dt   (work done by the drive)          [J]
//   y[6N + 1]        ∫ D dt      (energy dissipated)               [J]
//   y[6N + 2]        ∫ F_f dt    (friction impulse, for μ)         [N s]
// The three integrals are quadratures carried with the state so they are as
// accurate as the state itself: they feed the energy audit (§8) and μ (§7).

#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/case/placement.hpp"
#include "stickslip/model/contacts.hpp"
#include "stickslip/model/friction_law.hpp"

namespace stickslip {

// A sparse matrix pattern in compressed-row form (0-based) with values. The
// pattern is fixed when built; only values are refilled afterwards.
struct SparseJacobian {
  std::int64_t size = 0;
  std::vector<std::int64_t> row_start;  // size + 1 entries
  std::vector<std::int64_t> column;
  std::vector<double> value;
  // Values that do not depend on the state (the lattice), and where each
  // contact's 2×2 block is added to them (row-major slots into `value`).
  std::vector<double> constant_value;
  std::vector<std::array<std::int64_t, 4>> contact_slot;
  std::int64_t nonzeros() const { return static_cast<std::int64_t>(column.size()); }
};

// Which part of f a Jacobian belongs to: the contact forces alone (the stiff,
// block-diagonal part treated implicitly by IMEX methods), all of f, or all
// of f's rows for the friction sites' in-plane accelerations and no others
// (how each contact node is tied to the lattice, which the multirate stepper
// reads: O(N_c) entries, where the whole matrix holds ~200 a node).
enum class JacobianPart { contacts, full, site_rows };

struct EnergyTerms {
  double kinetic = 0.0;  // Σ m|w|²/2
  double elastic = 0.0;  // U of §3
  double drive = 0.0;    // Σ_top (k_d/2) |(v t, 0, 0) − u|²
  double total() const { return kinetic + elastic + drive; }
};

class System {
 public:
  static constexpr int kQuadratures = 3;
  enum Quadrature { work_in = 0, dissipated = 1, friction_impulse = 2 };

  System(const Case& c, std::vector<Contact> contacts);

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  int nz() const { return nz_; }
  std::int64_t num_nodes() const { return n_; }
  std::int64_t size() const { return 6 * n_ + kQuadratures; }
  std::int64_t node(int ix, int iy, int iz) const {
    return ix + nx_ * (iy + std::int64_t{ny_} * iz);
  }
  std::int64_t u_index(std::int64_t node, int k) const { return 3 * node + k; }
  std::int64_t w_index(std::int64_t node, int k) const { return 3 * n_ + 3 * node + k; }
  std::int64_t quadrature_index(Quadrature q) const { return 6 * n_ + q; }

  // "u^x of node (3, 4, 0)" for state index i, for diagnostics.
  std::string describe_component(std::int64_t i) const;
  // State index i as what it is: a node's u or w along an axis (kind 0-2:
  // u_x, u_y, u_z; 3-5: w_x, w_y, w_z) at (ix, iy, iz), or quadrature q
  // (kind 6 + q, the node −1).
  struct Component {
    int kind;
    int ix = -1, iy = -1, iz = -1;
  };
  Component component(std::int64_t i) const;

  // The friction interface: the contacts, their sites, the law and what is
  // decided per site or contact (model/contacts.hpp).
  const ContactSet& contact_set() const { return contact_set_; }

  // y at t = 0: at rest, or sliding (w^x = v everywhere); quadratures zero.
  void initial_state(InitialState initial, std::span<double> y) const;

  // f = f_explicit + f_implicit. The implicit part is the contact forces (on
  // the contacts' in-plane velocities); everything else is explicit. The
  // lattice's forces go to `threads` OpenMP threads (the run's budget,
  // ThreadBudget::now(), model/parallel_for.hpp); results do not depend on it.
  void rhs(double t, std::span<const double> y, std::span<double> ydot, int threads = 1) const;
  void rhs_explicit(double t, std::span<const double> y, std::span<double> ydot,
                    int threads = 1) const;
  void rhs_implicit(double t, std::span<const double> y, std::span<double> ydot) const;

  // The lattice's accelerations (elastic faces and cells, damping, drive
  // springs and dashpots to the plate; MODEL.md §3–5) at time t for
  // displacements u and velocities w (3N values each), into acc (3N). Affine
  // in (u, w); without the contacts. Solvers that exploit the lattice's
  // structure read its operator from here (by probing), never from a copy of
  // the stencil. On `threads` OpenMP threads, with the same result for any.
  void lattice_accelerations(double t, std::span<const double> u, std::span<const double> w,
                             std::span<double> acc, int threads = 1) const;

  // The quadratures' rates at (t, y), in Quadrature's order: P_in, D and F_f
  // (§7, §8); they depend on u and w only. f's last three rows.
  std::array<double, kQuadratures> quadrature_rates(double t, std::span<const double> y) const;

  // ∂f/∂y of `part`, with every diagonal entry of its rows present
  // (integrators form I − γJ in place). Quadrature rows are left zero:
  // nothing depends on them.
  SparseJacobian jacobian_pattern(JacobianPart part) const;
  // Refills the values of a matrix built by jacobian_pattern at y: only the
  // contact blocks depend on the state.
  void jacobian_values(std::span<const double> y, SparseJacobian& jac) const;

  // Observables.
  double friction_force(double t, std::span<const double> y) const;  // F_f of §5 [N]
  double normal_force() const { return normal_force_; }              // F_N of §7 [N]
  double coverage() const;                                           // θ realized
  EnergyTerms energy(double t, std::span<const double> y) const;
  double power_in(double t, std::span<const double> y) const;
  double dissipation(std::span<const double> y) const;
  // D's lattice part alone: the faces' dashpots and the drive's (§8) [W].
  double lattice_dissipation(std::span<const double> y) const;
  // Relative energy-audit residual [ΔE − ∫(P_in − D)] / ∫ P_in (§8), from y(t)
  // and the state it started from.
  double energy_residual(double t, std::span<const double> y, std::span<const double> y0) const;
  // The block's centre-of-mass x-velocity (all nodes have the same mass) [m/s].
  double block_velocity(std::span<const double> y) const;
  // ∫₀ᵗ Σ_c F^x_contact,c dt' (+ the block's momentum at t = 0) from the
  // momentum balance: the lattice's internal forces cancel (periodic in x and
  // y), so d/dt Σ m w_x = F_drive,x + F_contact,x, and the drive's impulse is
  // the friction impulse (a quadrature of y) plus its dashpots', m η Σ_top
  // (v t − u_x). Accurate wherever the state is [N s].
  double contact_impulse(double t, std::span<const double> y) const;

  // Exact μ of steady sliding at the drive velocity (§7).
  double steady_sliding_mu() const;

  // Derived constants, per unit mass where they enter the equations of motion.
  double mass() const { return mass_; }
  double g1() const { return g1_; }
  double g2() const { return g2_; }
  // k1 = m G1/a² of §2: one elastic spring's stiffness [N/m].
  double k1() const { return mass_ * g1_ / (a_ * a_); }
  // c_l = √(G1 + G2): the longitudinal sound speed [m/s].
  double longitudinal_speed() const { return std::sqrt(g1_ + g2_); }
  double spacing() const { return a_; }
  double drive_velocity() const { return v_; }
  // The displacement one elastic spring k1 takes to balance a site's full
  // contact force ε f0 (MODEL.md §6): the scale on which contact forces move
  // the lattice [m].
  double contact_displacement() const { return contact_force_scale_ / k1_over_m_; }

 private:
  // The lattice's springs and dashpots (MODEL.md §3, §5), described once:
  // the forces, the Jacobian, the dissipation and the energy all walk the
  // lattice through these, in this order (system.cpp). A new lattice term is
  // its coefficient (a member here, set in the constructor) and its lambda
  // in each of those four; a term between the top layer and the plate goes
  // in drive_acceleration too, which power_in reads, and friction_force and
  // contact_impulse read drive_stretch.
  //  - faces(iz, f): f(i, j) for every face of layer iz, node by node (iy
  //    slowest), its +x, +y and (below the top) +z neighbour j of node i;
  //  - cells(iz, f): f(corner) for every cell between layers iz and iz + 1,
  //    corner[8] its nodes in kCorners' order (system.cpp); none in the top layer;
  //  - top_layer(f): f(n) for every node of the top layer, tied to the plate;
  //  - driven(t, u, w, f): f(n, gap) for each of them, with gap the plate's
  //    displacement and velocity at t less the node's (u, w: 3N values each,
  //    as lattice_accelerations takes them).
  struct DriveGap {
    double du[3];  // (v t − u^x, −u^y, −u^z) [m]
    double dw[3];  // (v − w^x, −w^y, −w^z) [m/s]
  };
  template <class Face>
  void faces(int iz, Face&& face) const;
  template <class Cell>
  void cells(int iz, Cell&& cell) const;
  template <class Node>
  void top_layer(Node&& node_tied) const;
  template <class Driven>
  void driven(double t, const double* u, const double* w, Driven&& node_tied) const;
  // The drive's spring and dashpot on a top node, per unit mass, component k (§5).
  double drive_acceleration(const DriveGap& gap, int k) const {
    return kd_over_m_ * gap.du[k] + eta_ * gap.dw[k];
  }
  // Σ_top (v t − u^x): the drive springs' total stretch along x [m].
  double drive_stretch(double t, std::span<const double> y) const;

  int nx_, ny_, nz_;
  std::int64_t n_;
  double a_, mass_, g1_, g2_;
  double k1_over_m_, k2_over_m_, kd_over_m_;  // [1/s²]
  double eta_, eta_c_;                        // [1/s]
  double v_;                                  // drive velocity [m/s]
  double contact_force_scale_;                // ε f0 / m [m/s²]
  double normal_force_;
  double mu_prefactor_;               // τ_f / P0
  ContactSet contact_set_;            // the contacts, their sites and law
  std::vector<int> x_next_, y_next_;  // periodic neighbour along +x, +y
};

}  // namespace stickslip
