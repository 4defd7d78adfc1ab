#pragma once
// One fast contact advanced alone on sub-steps of its own (the fine level of
// the multirate stepper, multirate_integrator.hpp).
//
// Over one coarse step the rest of the lattice barely moves while a contact
// starts or stops slipping (waves cross a spacing in 1–1.7 µs; an arrest takes
// ~15 ns), so the contact node's in-plane motion x = (u_x, u_y, w_x, w_y) is
// integrated with the rest of the state given:
//     u' = w,   w' = Φ(t) + K u + C w + a_c(w),
// where K, C are the lattice's own in-plane stiffness and damping of that
// node (scalars: ∂a/∂u and ∂a/∂w of the node's own in-plane components, read
// off System's Jacobian) and Φ(t) is what every other component of the state
// contributes to its acceleration (the same Jacobian rows times the rest of the
// state, which the coarse level provides as a cubic in t). The lattice is
// linear, so this is exact but for Φ. The z components stay with the coarse
// level (the contact force has none).
//
// Each sub-step is the coarse level's ESDIRK (stiffly accurate, L-stable) with
// its embedded error estimate tested on the node's four components alone
// (weighted RMS ≤ 1), and its stages solved exactly in log-speed by
// System::site_stage, as every exact stage solve here is.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "stickslip/model/system.hpp"

namespace stickslip {

// An ESDIRK Butcher table with its embedding, loaded from SUNDIALS' own
// (arkode_butcher_dirk.h): the first stage explicit, the last row b
// (stiffly accurate).
struct EsdirkTable {
  int stages = 0, order = 0, embedded_order = 0;
  std::vector<double> a;  // row-major, stages × stages
  std::vector<double> b, d, c;
  double at(int i, int j) const { return a[static_cast<std::size_t>(i * stages + j)]; }
};
// dirk's table of that order (integrate/dirk_tables.hpp); std::logic_error
// for one that is not a stiffly accurate ESDIRK (order 2's SDIRK).
EsdirkTable esdirk_table(int order);

// The cubic Hermite between (0, y0, y0') and (h, y1, y1') at fraction s of h:
// y(s h) = a y0 + b y0' + c y1 + d y1' (the dense output of both levels).
struct HermiteWeights {
  double a, b, c, d;
};
inline HermiteWeights hermite_weights(double s, double h) {
  return {(1 + 2 * s) * (1 - s) * (1 - s), h * s * (1 - s) * (1 - s), s * s * (3 - 2 * s),
          h * s * s * (s - 1)};
}

// How site j's node is tied to the rest of the lattice, from System's Jacobian.
struct NodeCoupling {
  double stiffness = 0.0;  // K [1/s²]
  double damping = 0.0;    // C [1/s]
  // The largest coefficient with which one neighbour's acceleration reads
  // this node's u and w (the stiffness and damping are symmetric, so this
  // node's rows give them): how much a neighbour feels of an error in the node.
  double neighbour_stiffness = 0.0;  // [1/s²]
  double neighbour_damping = 0.0;    // [1/s]
  // Rows w_x, w_y of the node: the state components and coefficients of Φ.
  std::array<std::vector<std::int64_t>, 2> column;
  std::array<std::vector<double>, 2> value;
  // Φ at a state: Σ value · y[column].
  std::array<double, 2> forcing(const double* y) const;
};
// Every site's coupling. Throws std::invalid_argument where a node's own
// in-plane block is not K I, C I (lattices 1 node wide) or the node is
// driven (a one-layer lattice): there Φ would not be the whole rest.
std::vector<NodeCoupling> node_couplings(const System& system);

struct SubstepResult;

// Φ over one coarse step: a polynomial in x = τ / H, τ = t − t_n (what the
// coarse level gives), plus terms read off other fast contacts' sub-steps
// (a fast neighbour's own motion, which its coarse stand-in has only on
// average).
struct Forcing {
  static constexpr int kTerms = 8;
  double H = 1.0;
  std::array<std::array<double, kTerms>, 2> coefficient{};  // [component][power of x]
  struct FineTerm {
    int row;             // 0: x, 1: y
    double coefficient;  // ∂a/∂(that component)
    const SubstepResult* source;
    int component;  // of source's x: u_x, u_y, w_x, w_y
  };
  std::vector<FineTerm> fine_terms;
  std::array<double, 2> at(double tau) const;
  // Φ0 + τ Φ0' (the predictor before the coarse step exists).
  static Forcing taylor(double H, std::array<double, 2> value, std::array<double, 2> rate);
  // The polynomial through (τ_i, Φ_i), i < kTerms, the τ_i distinct: the
  // coarse step's stages.
  static Forcing through(double H, std::span<const double> tau,
                         std::span<const std::array<double, 2>> values);
};

// The state of the node's in-plane motion, with its derivative and the
// contact's acceleration a_c, at one time.
struct SubstepPoint {
  double tau = 0.0;                // since the coarse step's start [s]
  std::array<double, 4> x{}, f{};  // (u_x, u_y, w_x, w_y) and x'
  double dissipated = 0.0;         // ∫ −m a_c·w dt since the coarse step's start [J]
};

struct SubstepResult {
  std::vector<SubstepPoint> points;              // the start, then every accepted sub-step's end
  std::array<double, 2> contact_acceleration{};  // a_c at the end [m/s²]
  // ∫ a_c dτ and ∫ τ a_c dτ over the coarse step: what the coarse level is
  // handed (the contact's impulse and its first moment).
  std::array<double, 2> impulse{}, moment{};
  // The same of the node's own acceleration, a_c + K u + C w (all but Φ):
  // what the coarse stand-in passes on where it cancels its own K and C
  // (MultirateIntegrator::substep_fast).
  std::array<double, 2> own_impulse{}, own_moment{};
  long substeps = 0, rejected = 0;
  double last_substep = 0.0;  // the controller's next sub-step
  // x at τ in [0, H], by the cubic Hermite of the sub-step holding it.
  std::array<double, 4> at(double tau) const;
  double dissipated_at(double tau) const;  // linear within a sub-step
};

class ContactSubsteps {
 public:
  ContactSubsteps(const System& system, const EsdirkTable& table, double rtol,
                  std::array<double, 4> atol);

  // Advances site j's node from x0 (with a_c = a0 there) over [0, H] under
  // `forcing`, starting with sub-steps of `h_try`. Throws StageNotConverged
  // when the sub-steps fall below 1e-18 s or exceed max_substeps.
  SubstepResult advance(std::size_t j, const NodeCoupling& coupling, double H,
                        std::array<double, 4> x0, std::array<double, 2> a0, const Forcing& forcing,
                        double h_try) const;

  static constexpr long kMaxSubsteps = 100000;

 private:
  bool stages(std::size_t j, const NodeCoupling& coupling, const Forcing& forcing, double tau,
              double h, std::vector<std::array<double, 4>>& z,
              std::vector<std::array<double, 4>>& f, std::vector<std::array<double, 2>>& ac) const;
  double error_norm(double h, const std::array<double, 4>& x,
                    const std::vector<std::array<double, 4>>& f) const;

  const System& system_;
  const EsdirkTable& table_;
  double rtol_;
  std::array<double, 4> atol_;
};

}  // namespace stickslip
