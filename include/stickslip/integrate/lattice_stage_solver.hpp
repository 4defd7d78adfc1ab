#pragma once
// Exact solution of a fully implicit stage, z − γ f(t, z) = b, for all of f
// (lattice, contacts and the three quadratures), for dirk and bdf.
//
// The lattice is linear, so eliminating it leaves a nonlinear system on the
// 2 N_c contact velocities alone (derivation in the .cpp; with patches, a
// contact here is a friction site of System). That system is
// solved by Newton in variables where it is smooth, with every contact's own
// equation solved exactly in log-speed as imex's stage solve does: no Newton
// iteration ever runs on the 10¹⁰–10¹⁵ s⁻¹ contact stiffness near rest that
// stalls Newton on the whole state (MODEL.md §12). The lattice costs one FFT
// solve (LatticeSolver) per stage; nothing here knows of SUNDIALS.

#include <Eigen/Dense>
#include <Eigen/SparseLU>
#include <array>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "stickslip/integrate/lattice_solver.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

class LatticeStageSolver {
 public:
  // A stage that leaves a contact past its peak force with γ λ above this
  // (λ: the growth rate of its slip) is refused with StageNotConverged: the
  // integrator then retries a shorter step (why: solve() in the .cpp).
  static constexpr double kMaxGammaLambda = 1.0;

  // How the contacts' Newton steps are solved (solve_contacts in the .cpp):
  // with a dense LU of their 2 N_c × 2 N_c Newton matrix, or matrix free, by
  // GMRES on the FFT coupling preconditioned with a sparse LU of the matrix's
  // near field. `by_count` picks by the number of friction sites
  // (uses_dense_lu); the others are for tests.
  enum class ContactNewton { by_count, dense_lu, matrix_free };
  // The rule: a dense LU up to this many friction sites, matrix free above
  // (measured: docs/notes/performance-history.md, "The contacts' Newton steps without a
  // dense matrix").
  // 1000, not the ~200 where the two cost the same per step in creep: over a
  // whole 30x30x10 block slip (448 sites) the matrix-free steps took 4.1 M
  // Krylov iterations against the dense path's 12 558, and 1.5x its CPU.
  static constexpr std::size_t kMaxDenseSites = 1000;
  static bool uses_dense_lu(std::size_t sites) { return sites <= kMaxDenseSites; }

  // Its loops and the lattice solver's run on `threads` (the run's budget,
  // IntegratorOptions::threads); none: one thread.
  explicit LatticeStageSolver(const System& system, double max_gamma_lambda = kMaxGammaLambda,
                              ContactNewton contact_newton = ContactNewton::by_count,
                              std::shared_ptr<const ThreadBudget> threads = nullptr);

  // z holds b on entry and the solution on return. `predictor` (the
  // integrator's guess for z) picks among several roots on the
  // velocity-weakening branch and starts Newton; `weights` are the error
  // weights 1/(rtol |y| + atol): the contacts' speeds are converged to 1e-6 of
  // the integrator's tolerance. Returns the Newton iterations on the
  // contacts' coupled speeds; throws StageNotConverged (model/friction_law.hpp)
  // when they do not converge or a stage is refused (kMaxGammaLambda), and
  // the integrator then retries with a smaller step.
  long solve(double t, double gamma, std::span<const double> predictor,
             std::span<const double> weights, std::span<double> z);

  // Sites whose contact acceleration is given instead of their law (the
  // multirate stepper's fast contacts, which it integrates on sub-steps of
  // their own): a_c of site j is `acceleration` + `rate` s (s its in-plane
  // speed at the stage; rate ≥ 0, γ ḡ rate < 1) in the stages solved until
  // released, its contact dissipation is left out of the dissipation
  // quadrature (the stepper adds what the sub-steps integrate), and it is
  // not held to γλ ≤ max_gamma_lambda.
  void prescribe(std::size_t site, std::array<double, 2> acceleration, double rate = 0.0);
  void release_all();
  // Site j's a_c as the last stage solved had it ((Σ − β)/(γ ḡ): the stage
  // equation's, not the law's at the stage's speed, which near rest is noise).
  std::array<double, 2> contact_acceleration(std::size_t j) const {
    const double scale = gamma_ * self_green_;
    return {(sigma_(2 * j) - beta_(2 * j)) / scale, (sigma_(2 * j + 1) - beta_(2 * j + 1)) / scale};
  }
  // After a StageNotConverged for γλ: the sites that exceeded it.
  const std::vector<std::size_t>& refused_sites() const { return refused_sites_; }

  const LatticeSolver& lattice() const { return lattice_; }
  // LU factorizations of the contacts' Newton matrix so far, and Krylov
  // iterations on the contacts' Newton steps (each one coupling product and
  // one solve with the LU).
  // Matrix free: factorizations of the near-field preconditioner instead,
  // and each Krylov iteration one coupling product and one sparse solve.
  long contact_factorizations() const { return factorizations_; }
  bool matrix_free() const { return matrix_free_; }
  long krylov_iterations() const { return krylov_iterations_; }

 private:
  void set_gamma(double gamma);
  long solve_contacts(std::span<const double> predictor, std::span<const double> weights);
  void factorize_jacobian();
  void apply_coupling(const Eigen::VectorXd& x, Eigen::VectorXd& out);
  Eigen::VectorXd solve_with_lu(const Eigen::VectorXd& r) const;
  void apply_jacobian(const Eigen::VectorXd& v, Eigen::VectorXd& out);
  struct JacobianProduct;  // GMRES's operator over apply_jacobian (.cpp)
  template <class Solve>
  Eigen::Index weighted_gmres(const Solve& approximate, double relative,
                              Eigen::Index max_iterations, bool& converged);
  bool krylov_step(double relative, Eigen::Index max_iterations);
  // Site i's offset from site j, wrapped, as LatticeSolver::green_wrapped
  // takes it (sites lie in [0, Nx) × [0, Ny): one conditional add, no division).
  std::int64_t site_offset(std::size_t i, std::size_t j) const {
    int dx = site_ix_[i] - site_ix_[j], dy = site_iy_[i] - site_iy_[j];
    if (dx < 0) dx += nx_;
    if (dy < 0) dy += ny_;
    return dx + std::int64_t{nx_} * dy;
  }
  std::array<double, 4> newton_block(std::size_t i, std::size_t j,
                                     const std::array<double, 4>& e) const;
  void find_near_field();
  void factorize_near_field();
  void near_field_step(double norm);
  // How a Newton iteration solved J δ = −F(β) for its step (newton_step).
  enum class StepSolve {
    fresh_lu,  // with an LU built at this β: Newton's step
    kept_lu,   // with the LU kept from an earlier β, γ or stage: modified Newton's
    krylov,    // by GMRES preconditioned with the kept LU: Newton's
  };
  StepSolve newton_step(bool krylov, double norm, double lu_in_krylov, Eigen::Index max_krylov);

  int loop_threads() const { return threads_ ? threads_->now() : 1; }

  const System& system_;
  double max_gamma_lambda_;
  std::shared_ptr<const ThreadBudget> threads_;  // the run's; none: one thread
  LatticeSolver lattice_;
  std::int64_t nodes_;
  std::size_t sites_;
  std::vector<std::int64_t> site_w_;  // state index of each friction site's w^x
  int nx_, ny_;
  std::vector<int> site_ix_, site_iy_;  // each friction site's lattice position
  bool matrix_free_;
  // Each site's node in the bottom layer, ix + Nx iy (LatticeSolver::surface_field).
  std::vector<std::int64_t> site_surface_;
  // For the γ last seen: the bottom layer's self Green's function ḡ (the
  // mean of its xx and yy entries), which scales the coupling
  // H = (G − ḡ I)/ḡ between the contacts' velocities (2 N_c × 2 N_c).
  double gamma_ = -1.0;
  double self_green_ = 0.0;
  // Scratch.
  std::vector<double> zero_, acc_;
  Eigen::VectorXd free_speed_, beta_, sigma_, residual_, trial_, step_, product_, trial_force_,
      krylov_force_;
  Eigen::VectorXd newton_weight_;  // the sites' speeds' error weights (solve_contacts)
  // The contacts' Newton matrix, factorized in place (for a γ and β since
  // passed); empty when it is to be rebuilt. In single precision: Newton's
  // residual is exact, so the matrix sets only how fast the iteration
  // contracts, not where it ends, and a solve, which reads the whole matrix
  // (its cost at thousands of contacts, ~7 times a stage), reads half the
  // bytes; half the memory too.
  Eigen::MatrixXf jacobian_;
  std::optional<Eigen::PartialPivLU<Eigen::Ref<Eigen::MatrixXf>>> jacobian_lu_;
  long factorizations_ = 0;
  long krylov_iterations_ = 0;
  // Krylov iterations beyond one a step spent with the LU since it was built.
  double stale_krylov_ = 0.0;
  // Matrix free: the near field, pairs of sites (i, j) within
  // kNearFieldRadius lattice spacings (the .cpp), j's index in near_site_
  // from near_start_[i] to near_start_[i + 1]; the Newton matrix restricted
  // to it, in double precision, and its sparse LU (pattern analysed once).
  std::vector<std::size_t> near_start_, near_site_;
  Eigen::SparseMatrix<double> near_matrix_;
  Eigen::SparseLU<Eigen::SparseMatrix<double>> near_lu_;
  bool near_lu_ready_ = false;
  // Krylov iterations of the first step after the near-field LU was built.
  Eigen::Index fresh_krylov_ = 0;
  std::vector<ContactStage> stages_;
  std::vector<double> predicted_speed_;
  std::vector<char> prescribed_;  // per site
  std::vector<std::array<double, 2>> prescribed_acceleration_;
  std::vector<double> prescribed_rate_;
  std::vector<std::size_t> prescribed_sites_, refused_sites_;
};

}  // namespace stickslip
