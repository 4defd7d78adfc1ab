#include "stickslip/integrate/lattice_stage_solver.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
// Eigen's GMRES (Householder Arnoldi, left preconditioned), called as its
// algorithm function: the operator here is matrix free (one FFT product) and
// the preconditioner a kept LU in single precision, which the function takes
// as they are; the GMRES class would want both wrapped as Eigen expressions.
#include <unsupported/Eigen/IterativeSolvers>

#include "stickslip/model/parallel_for.hpp"

namespace stickslip {

// The stage equation, with f split as MODEL.md §3–6 define it
// (a_L: lattice accelerations, affine; a_c: contact accelerations on the
// in-plane velocities s = P w of the contact nodes; P picks them):
//     u − γ w = b_u,   w − γ (a_L(t, u, w) + Pᵀ a_c(P w)) = b_w.
// a_L(t, u, w) = −K u − C w + g(t), so u = b_u + γ w leaves
//     M w = r + γ Pᵀ a_c(P w),   M = I + γ C + γ² K,   r = b_w + γ a_L(t, b_u, 0),
// and w = w0 + γ M⁻¹ Pᵀ a_c with w0 = M⁻¹ r. On the contacts, with
// G = P M⁻¹ Pᵀ (the bottom layer's Green's function between contact sites):
//     s = s0 + γ G a_c(s),   s0 = P w0.
// Split G = ḡ (I + H), ḡ its mean self term. With β = s0 + γ ḡ H a_c(s), each
// contact's own equation s_i − γ ḡ a_c(s_i) = β_i is imex's scalar stage
// equation, solved exactly in log-speed: s_i = Σ_i(β_i) (System::site_stage),
// and a_c(s) = (Σ(β) − β)/(γ ḡ). What remains is
//     F(β) = β − s0 − H (Σ(β) − β) = 0,   ∂F/∂β = I + H (I − E),
// E = blockdiag(∂Σ_i/∂β_i). E is bounded (‖E_i‖ ≤ 1 where the force rises with
// speed), so Newton on β is well conditioned where Newton on s would meet
// ∂a_c/∂s ~ 1e15 s⁻¹. One contact alone, or contacts the lattice does not
// couple (H = 0), need no iteration at all.

LatticeStageSolver::LatticeStageSolver(const System& system, double max_gamma_lambda,
                                       ContactNewton contact_newton,
                                       std::shared_ptr<const ThreadBudget> threads)
    : system_(system),
      max_gamma_lambda_(max_gamma_lambda),
      threads_(threads),
      lattice_(system, std::move(threads)),
      nodes_(system.num_nodes()),
      sites_(system.contact_set().sites().size()),
      nx_(system.nx()),
      ny_(system.ny()),
      matrix_free_(contact_newton == ContactNewton::matrix_free ||
                   (contact_newton == ContactNewton::by_count && !uses_dense_lu(sites_))),
      zero_(static_cast<std::size_t>(3 * nodes_), 0.0),
      acc_(zero_.size()) {
  const auto& sites = system.contact_set().sites();
  for (std::size_t i = 0; i < sites_; ++i) site_w_.push_back(system.w_index(sites[i].node, 0));
  for (const auto& site : sites) {
    site_ix_.push_back(site.ix);
    site_iy_.push_back(site.iy);
  }
  for (std::size_t i = 0; i < sites_; ++i)
    site_surface_.push_back(sites[i].ix + std::int64_t{system.nx()} * sites[i].iy);
  const auto n = static_cast<Eigen::Index>(2 * sites_);
  for (auto* v : {&free_speed_, &beta_, &sigma_, &residual_, &trial_, &step_, &product_,
                  &krylov_force_, &newton_weight_})
    v->resize(n);
  stages_.resize(sites_);
  predicted_speed_.resize(sites_);
  prescribed_.assign(sites_, 0);
  prescribed_acceleration_.assign(sites_, {0.0, 0.0});
  prescribed_rate_.assign(sites_, 0.0);
  // Eigen's LU runs its block updates on every OpenMP thread by default, and
  // chooses its products' blocking by thread count: results could depend on
  // the number of threads. It also mostly spin-waited on these ≤ 900² matrices
  // (half the run's time on theta05 in a profile, with a sweep's other point
  // on the other core). A run's threads ([solver] threads) go to the loops
  // whose work is split the same way for any count (see solve_contacts).
  Eigen::setNbThreads(1);
  if (matrix_free_) find_near_field();
}

void LatticeStageSolver::prescribe(std::size_t site, std::array<double, 2> acceleration,
                                   double rate) {
  if (!prescribed_[site]) prescribed_sites_.push_back(site);
  prescribed_[site] = 1;
  prescribed_acceleration_[site] = acceleration;
  prescribed_rate_[site] = rate;
}

void LatticeStageSolver::release_all() {
  for (const std::size_t j : prescribed_sites_) prescribed_[j] = 0;
  prescribed_sites_.clear();
}

void LatticeStageSolver::set_gamma(double gamma) {
  lattice_.set_gamma(gamma);
  if (gamma == gamma_) return;
  gamma_ = gamma;
  self_green_ = 0.5 * (lattice_.green(0, 0, 0, 0) + lattice_.green(0, 0, 1, 1));
}

// out = H x = P G Pᵀ x / ḡ − x by FFT over the bottom layer (LatticeSolver::
// convolve_surface): N_c contacts cost one 2D transform of the layer, not the
// N_c² products of H as a matrix (≈ 80 % of a 60×60×10 run at θ = 0.5 when
// they were: 103 MB of H read at every Newton iteration).
void LatticeStageSolver::apply_coupling(const Eigen::VectorXd& x, Eigen::VectorXd& out) {
  // Few contacts on a wide layer (the Fig. 10 pairs): the N_c² Green's-
  // function lookups cost less than the layer's transform (a 2-contact pair
  // on 6×6×4 ran 15 % slower a step by FFT).
  if (sites_ * sites_ <= static_cast<std::size_t>(lattice_.surface_field().size() / 2)) {
    for (std::size_t i = 0; i < sites_; ++i)
      for (int a = 0; a < 2; ++a) {
        double sum = 0.0;
        for (std::size_t j = 0; j < sites_; ++j) {
          const std::int64_t offset = site_offset(i, j);
          sum += lattice_.green_wrapped(offset, a, 0) * x(2 * j) +
                 lattice_.green_wrapped(offset, a, 1) * x(2 * j + 1);
        }
        out(2 * i + a) = sum / self_green_ - x(2 * i + a);
      }
    return;
  }
  const auto field = lattice_.surface_field();
  const std::size_t layer = field.size() / 2;
  std::fill(field.begin(), field.end(), 0.0);
  for (std::size_t i = 0; i < sites_; ++i) {
    field[site_surface_[i]] = x(2 * i);
    field[layer + site_surface_[i]] = x(2 * i + 1);
  }
  lattice_.convolve_surface();
  for (std::size_t i = 0; i < sites_; ++i) {
    out(2 * i) = field[site_surface_[i]] / self_green_ - x(2 * i);
    out(2 * i + 1) = field[layer + site_surface_[i]] / self_green_ - x(2 * i + 1);
  }
}

long LatticeStageSolver::solve(double t, double gamma, std::span<const double> predictor,
                               std::span<const double> weights, std::span<double> z) {
  const std::size_t n3 = static_cast<std::size_t>(3 * nodes_);
  const auto u = z.subspan(0, n3), w = z.subspan(n3, n3);
  refused_sites_.clear();
  set_gamma(gamma);
  // r = b_w + γ a_L(t, b_u, 0), then w0 = M⁻¹ r, held by the lattice solver.
  system_.lattice_accelerations(t, u, zero_, acc_, loop_threads());
  for (std::size_t r = 0; r < n3; ++r) w[r] += gamma * acc_[r];
  lattice_.begin_solve(w);

  long iterations = 0;
  if (sites_ > 0) {
    // s0 = P w0.
    const auto field = lattice_.surface_field();
    const std::size_t layer = field.size() / 2;
    lattice_.held_surface_velocity();
    for (std::size_t i = 0; i < sites_; ++i)
      for (std::size_t k = 0; k < 2; ++k)
        free_speed_(2 * i + k) = field[k * layer + site_surface_[i]];
    iterations = solve_contacts(predictor, weights);
    // w = w0 + M⁻¹ (γ Pᵀ a_c), γ a_c = (Σ(β) − β)/ḡ.
    std::fill(field.begin(), field.end(), 0.0);
    for (std::size_t i = 0; i < sites_; ++i)
      for (std::size_t k = 0; k < 2; ++k)
        field[k * layer + site_surface_[i]] = (sigma_(2 * i + k) - beta_(2 * i + k)) / self_green_;
    lattice_.add_surface_source();
  }
  lattice_.finish_solve(w);
  for (std::size_t r = 0; r < n3; ++r) u[r] += gamma * w[r];

  // The quadratures: q = b_q + γ q'(t, z), their rates depending on u and w only.
  auto rates = system_.quadrature_rates(t, z);
  for (const std::size_t j : prescribed_sites_) {  // −m a_c·s of their law, left out
    const std::array<double, 2> s{z[site_w_[j]], z[site_w_[j] + 1]};
    const auto a = system_.contact_set().site_acceleration(j, s);
    rates[System::dissipated] += system_.mass() * (a[0] * s[0] + a[1] * s[1]);
  }
  const auto first = static_cast<std::size_t>(system_.quadrature_index(System::work_in));
  for (std::size_t q = 0; q < rates.size(); ++q) z[first + q] += gamma * rates[q];

  // A stage that leaves a contact past its peak force with γ λ > 1 (λ: the
  // growth rate of its slip, System::weakening_rate) is refused, and the
  // integrator retries a shorter step. Past γ λ = 1 the stage equation is no
  // longer monotone in that contact's speed, and the step damps the slip's
  // growth where the error estimate, built from two damped answers, cannot
  // see it: Fig. 9 at rtol 1e-4 stepped over the block's slip in one step of
  // 5e-4 s ending at h λ = 5 448, and a pair at rtol 1e-2 over its slips.
  for (std::size_t j = 0; j < sites_; ++j)
    if (!prescribed_[j] &&
        gamma * system_.contact_set().site_weakening_rate(j, {z[site_w_[j]], z[site_w_[j] + 1]}) >
            max_gamma_lambda_)
      refused_sites_.push_back(j);
  if (!refused_sites_.empty())
    throw StageNotConverged(
        "a contact's slip grows faster than the step resolves (gamma lambda > 1)");
  return iterations;
}

// Block (i, j) of ∂F/∂β = I + H − H E, row-major: δ_ij I + H_ij (I − E_j),
// H_ij = G_ij/ḡ − δ_ij I, E_j = ∂Σ_j/∂β_j (`e`). The dense LU and the near
// field's both fill from it.
std::array<double, 4> LatticeStageSolver::newton_block(std::size_t i, std::size_t j,
                                                       const std::array<double, 4>& e) const {
  const std::int64_t offset = site_offset(i, j);
  std::array<double, 4> block{};
  for (int a = 0; a < 2; ++a) {
    const double diagonal = i == j ? 1.0 : 0.0;
    const double h0 =
        lattice_.green_wrapped(offset, a, 0) / self_green_ - (a == 0 ? diagonal : 0.0);
    const double h1 =
        lattice_.green_wrapped(offset, a, 1) / self_green_ - (a == 1 ? diagonal : 0.0);
    block[static_cast<std::size_t>(2 * a)] =
        h0 - (h0 * e[0] + h1 * e[2]) + (a == 0 ? diagonal : 0.0);
    block[static_cast<std::size_t>(2 * a + 1)] =
        h1 - (h0 * e[1] + h1 * e[3]) + (a == 1 ? diagonal : 0.0);
  }
  return block;
}

// ∂F/∂β = I + H − H E at the β whose ∂Σ/∂β are in stages_, factorized in
// place in single precision (why: the header; 0.8 GB at 7 171 contacts). H's
// entries are the Green's function's, looked up (offsets wrapped without
// integer division, site_offset: the divisions were 9 % of a Fig. 9 block
// slip when H was refilled at every γ).
void LatticeStageSolver::factorize_jacobian() {
  jacobian_lu_.reset();
  const auto n = static_cast<Eigen::Index>(2 * sites_);
  jacobian_.resize(n, n);
  auto& jacobian = jacobian_;
  const auto fill_columns = [&](std::size_t j) {
    const auto& e = stages_[j].ds_db;
    const auto c0 = static_cast<Eigen::Index>(2 * j), c1 = c0 + 1;
    for (std::size_t i = 0; i < sites_; ++i) {
      const auto block = newton_block(i, j, e);
      for (int a = 0; a < 2; ++a) {
        const auto r = static_cast<Eigen::Index>(2 * i + a);
        jacobian(r, c0) = static_cast<float>(block[2 * a]);
        jacobian(r, c1) = static_cast<float>(block[2 * a + 1]);
      }
    }
  };
  parallel_for(loop_threads(), static_cast<std::int64_t>(sites_),
               [&](std::int64_t j) { fill_columns(static_cast<std::size_t>(j)); });
  jacobian_lu_.emplace(jacobian_);
  ++factorizations_;
  stale_krylov_ = 0.0;
}

// The kept LU's answer to J x = r, in its single precision.
Eigen::VectorXd LatticeStageSolver::solve_with_lu(const Eigen::VectorXd& r) const {
  return jacobian_lu_->solve(r.cast<float>()).cast<double>();
}

// J v = v + H (I − E) v at the β whose ∂Σ/∂β are in stages_: one coupling
// product, no matrix.
void LatticeStageSolver::apply_jacobian(const Eigen::VectorXd& v, Eigen::VectorXd& out) {
  for (std::size_t i = 0; i < sites_; ++i) {
    const auto& e = stages_[i].ds_db;
    const double v0 = v(2 * i), v1 = v(2 * i + 1);
    krylov_force_(2 * i) = v0 - (e[0] * v0 + e[1] * v1);
    krylov_force_(2 * i + 1) = v1 - (e[2] * v0 + e[3] * v1);
  }
  apply_coupling(krylov_force_, out);
  out += v;
}

namespace {

// Newton on F(β) = 0 (solve_contacts).
constexpr int kMaxIterations = 60;
// Converged when ‖F‖, in the integrator's error weights, is at most this
// (1e-6 of the integrator's tolerance).
constexpr double kTolerance = 1e-6;
// No decrease even along Newton's own step, with ‖F‖ at most this: rounding,
// not divergence, and the solve is accepted where it is.
constexpr double kStagnated = 1e-3;
// Backtracking halves the step while the residual grows (the
// velocity-weakening branch), down to this fraction of it.
constexpr double kMinStepFraction = 1.0 / 64;
// Inexact Newton: GMRES solves to kForcing times what is left to gain
// (kTolerance/‖F‖) of its preconditioned residual, clamped to
// [kMinForcing, kMaxForcing]: a little more accurate than the step's own
// progress.
constexpr double kForcing = 0.1;
constexpr double kMinForcing = 1e-3;
constexpr double kMaxForcing = 0.1;
// GMRES restarts after this many iterations: the Arnoldi basis is
// n × (restart + 1) doubles, allocated and cleared at each call.
constexpr Eigen::Index kGmresRestart = 30;
// Matrix free: GMRES's iterations per Newton step at most.
constexpr Eigen::Index kMaxMatrixFreeKrylov = 300;

// What an LU of the contacts' 2 N_c × 2 N_c Newton matrix costs, counted in
// the iterations it saves (measured on 15×15×10 and 30×30×10 and 60×60×10:
// docs/notes/performance-history.md).
struct LuPrice {
  // In modified-Newton iterations (steps with the kept LU): 2 N_c /
  // kUnknownsPerIteration, at least kMinIterations.
  static constexpr double kMinIterations = 5.0;
  static constexpr double kUnknownsPerIteration = 20.0;
  // In Krylov iterations: n / kUnknownsPerKrylov for n = 2 N_c, at least
  // kMinKrylov (the LU's n³ flops against a solve's n² bytes; at n = 3 586,
  // 60×60×10: 3.7 s against 5.6 ms).
  static constexpr double kMinKrylov = 10.0;
  static constexpr double kUnknownsPerKrylov = 5.0;

  explicit LuPrice(std::size_t sites)
      : iterations(
            std::max(kMinIterations, static_cast<double>(2 * sites) / kUnknownsPerIteration)),
        krylov(std::max(kMinKrylov, static_cast<double>(2 * sites) / kUnknownsPerKrylov)),
        max_krylov(static_cast<Eigen::Index>(krylov / 2.0)) {}

  double iterations;
  double krylov;
  // A Krylov step that needs more than half an LU's price is not worth
  // finishing with the old LU.
  Eigen::Index max_krylov;
};

// Whether modified Newton, having gone from ‖F‖ = `norm` to `trial_norm` in
// iteration `it`, would need more iterations to converge at that rate than an
// LU costs, or than are left.
bool too_slow(double norm, double trial_norm, int it, const LuPrice& price) {
  const double rate = trial_norm / norm;
  const double remaining = std::log(kTolerance / trial_norm) / std::log(rate);
  return remaining > price.iterations || it + 1 + remaining > kMaxIterations;
}

}  // namespace

// Matrix free (above kMaxDenseSites): no dense matrix is built. Newton's
// step is solved by GMRES on the exact product J v = v + H (I − E) v (one FFT
// coupling product), preconditioned by a sparse LU of J's near field: the
// blocks J_ij = δ_ij I + H_ij (I − E_j) of sites i, j at most
// kNearFieldRadius lattice spacings apart in x and in y. H decays with
// distance, so the near field holds the part of J that changes fastest from
// site to site; what it leaves out is smooth over the contacts and GMRES
// resolves it in a few iterations. The near field has at most 9 blocks a row
// (radius 1), so its memory and its LU's fill stay O(N_c) in practice, not the
// dense matrix's 16 N_c² bytes and N_c³ flops.
namespace {
// Sites at most this many lattice spacings apart in x and in y are the near
// field. Measured (docs/notes/performance-history.md): on 60×60×10 at θ = 0.498 GMRES took
// the same iterations for radii 0 (block Jacobi) to 3, radius 2 a 1.4× slower
// step than 1 in its larger LU and solves; on 200 contacts at half coverage at
// γ = 1e-4 (tests/test_lattice_solver.cpp), ~12, ~9 and ~6 iterations a
// Newton step for radii 0, 1 and 2.
constexpr int kNearFieldRadius = 1;
// The near field's LU is rebuilt when GMRES needs more than this many times
// the iterations it took just after the LU was built (at least 2).
constexpr double kNearFieldRebuild = 2.0;
}  // namespace

void LatticeStageSolver::find_near_field() {
  std::vector<std::int64_t> site_at(static_cast<std::size_t>(nx_) * ny_, -1);
  for (std::size_t j = 0; j < sites_; ++j)
    site_at[static_cast<std::size_t>(site_ix_[j] + std::int64_t{nx_} * site_iy_[j])] =
        static_cast<std::int64_t>(j);
  // Offsets within the radius, each periodic image once.
  const int rx = std::min(kNearFieldRadius, (nx_ - 1) / 2),
            ry = std::min(kNearFieldRadius, (ny_ - 1) / 2);
  near_start_.assign(1, 0);
  near_site_.clear();
  for (std::size_t i = 0; i < sites_; ++i) {
    for (int dy = -ry; dy <= ry; ++dy)
      for (int dx = -rx; dx <= rx; ++dx) {
        const int x = (site_ix_[i] + dx + nx_) % nx_, y = (site_iy_[i] + dy + ny_) % ny_;
        const std::int64_t j = site_at[static_cast<std::size_t>(x + std::int64_t{nx_} * y)];
        if (j >= 0) near_site_.push_back(static_cast<std::size_t>(j));
      }
    near_start_.push_back(near_site_.size());
  }
  const auto n = static_cast<Eigen::Index>(2 * sites_);
  std::vector<Eigen::Triplet<double>> pattern;
  pattern.reserve(4 * near_site_.size());
  for (std::size_t i = 0; i < sites_; ++i)
    for (std::size_t k = near_start_[i]; k < near_start_[i + 1]; ++k)
      for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
          pattern.emplace_back(static_cast<Eigen::Index>(2 * i + a),
                               static_cast<Eigen::Index>(2 * near_site_[k] + b), 1.0);
  near_matrix_.resize(n, n);
  near_matrix_.setFromTriplets(pattern.begin(), pattern.end());
  near_matrix_.makeCompressed();
  near_lu_.analyzePattern(near_matrix_);
}

// J's near field at the β whose ∂Σ/∂β are in stages_, into near_matrix_'s
// fixed pattern, and its sparse LU.
void LatticeStageSolver::factorize_near_field() {
  near_matrix_.coeffs().setZero();
  for (std::size_t i = 0; i < sites_; ++i)
    for (std::size_t k = near_start_[i]; k < near_start_[i + 1]; ++k) {
      const std::size_t j = near_site_[k];
      const auto block = newton_block(i, j, stages_[j].ds_db);
      const auto c0 = static_cast<Eigen::Index>(2 * j), c1 = c0 + 1;
      for (int a = 0; a < 2; ++a) {
        const auto r = static_cast<Eigen::Index>(2 * i + a);
        near_matrix_.coeffRef(r, c0) = block[2 * a];
        near_matrix_.coeffRef(r, c1) = block[2 * a + 1];
      }
    }
  near_lu_.factorize(near_matrix_);
  if (near_lu_.info() != Eigen::Success)
    throw StageNotConverged("the contacts' near-field Newton matrix is singular");
  near_lu_ready_ = true;
  ++factorizations_;
}

// GMRES's operator, matrix free, in Newton's weights D (the integrator's
// error weights of the sites' speeds, which Newton's convergence test reads):
// y ↦ D J D⁻¹ y, J v = v + H (I − E) v one FFT coupling product
// (apply_jacobian).
struct LatticeStageSolver::JacobianProduct {
  LatticeStageSolver* solver;
  Eigen::Index rows() const { return solver->step_.size(); }
  Eigen::Index cols() const { return rows(); }
  Eigen::VectorXd operator*(const Eigen::VectorXd& y) const {
    Eigen::VectorXd out(y.size());
    solver->apply_jacobian(y.cwiseQuotient(solver->newton_weight_), out);
    return out.cwiseProduct(solver->newton_weight_);
  }
};

// Newton's step J δ = −F(β) into step_ by GMRES, preconditioned with
// `approximate` (a solve with an approximation of J), to `relative` of the
// preconditioned residual; returns GMRES's iterations and sets `converged`.
// GMRES works on D J D⁻¹ (D δ) = −D F, so that its residual norm weighs each
// site as Newton's test does. Unweighted, a stuck contact's residual (weight
// ~3e9 s/m at rtol 1e-5) counts for nothing beside a slipping one's (~1e6):
// on a 15×15×10 multirate run, GMRES's steps stopped decreasing Newton's norm
// at 1e-3–0.1 with stuck contacts as its largest terms, the coarse stages
// failed from 8e-9 s steps up, and the run crawled at ~2e-9 s a step.
template <class Solve>
Eigen::Index LatticeStageSolver::weighted_gmres(const Solve& approximate, double relative,
                                                Eigen::Index max_iterations, bool& converged) {
  struct Preconditioner {
    const Solve* approximate;
    const Eigen::VectorXd* weight;
    Eigen::VectorXd solve(const Eigen::VectorXd& r) const {
      return (*approximate)(r.cwiseQuotient(*weight)).cwiseProduct(*weight);
    }
  };
  const Eigen::VectorXd rhs = -residual_.cwiseProduct(newton_weight_);
  Eigen::VectorXd scaled = Eigen::VectorXd::Zero(rhs.size());
  Eigen::Index iterations = max_iterations;
  double error = relative;
  Eigen::internal::gmres(JacobianProduct{this}, rhs, scaled,
                         Preconditioner{&approximate, &newton_weight_}, iterations,
                         std::min<Eigen::Index>(max_iterations, kGmresRestart), error);
  step_ = scaled.cwiseQuotient(newton_weight_);
  krylov_iterations_ += iterations;
  converged = error <= relative;
  return iterations;
}

// Newton's step J δ = −F(β), by GMRES preconditioned with the kept LU (built
// at an earlier β, γ or stage). The LU's own step is modified Newton's; the
// Krylov iterations correct it for how far J has moved since, each for one
// coupling product and one triangular solve instead of an LU. Returns
// whether the step reached `relative` (of the preconditioned residual).
bool LatticeStageSolver::krylov_step(double relative, Eigen::Index max_iterations) {
  bool converged = false;
  weighted_gmres([this](const Eigen::VectorXd& r) { return solve_with_lu(r); }, relative,
                 max_iterations, converged);
  return converged;
}

// Newton's step, matrix free: GMRES on J preconditioned by the near field's
// sparse LU, kept across iterations, stages and steps (J moves with β and γ)
// and rebuilt at this β when GMRES needs more than kNearFieldRebuild times the
// iterations it took just after the last build, or does not converge.
void LatticeStageSolver::near_field_step(double norm) {
  const double relative = std::clamp(kForcing * kTolerance / norm, kMinForcing, kMaxForcing);
  const auto near_field = [this](const Eigen::VectorXd& r) -> Eigen::VectorXd {
    return near_lu_.solve(r);
  };
  for (bool fresh = false;;) {
    if (!near_lu_ready_) {
      factorize_near_field();
      fresh = true;
    }
    bool converged = false;
    const Eigen::Index iterations =
        weighted_gmres(near_field, relative, kMaxMatrixFreeKrylov, converged);
    if (fresh) {  // converged or not: the best step at hand
      fresh_krylov_ = iterations;
      return;
    }
    const double limit =
        kNearFieldRebuild * static_cast<double>(std::max<Eigen::Index>(fresh_krylov_, 2));
    if (converged && static_cast<double>(iterations) <= limit) return;
    near_lu_ready_ = false;  // stale: rebuilt at the next step, or now if GMRES failed
    if (converged) return;
  }
}

// The Newton step δ (into step_) for J δ = −F(β), F(β) in residual_, and the
// LU's refresh policy: the LU is built where there is none; by GMRES
// (`krylov`: the kept LU's own steps went wrong or slow in this solve) while
// it preconditions well, and rebuilt at this β when GMRES does not converge
// in `max_krylov`; dropped (rebuilt at the next step) when the Krylov
// iterations it has cost beyond one a step since it was built (what a fresh
// one would need) add up to its price. So a stale LU costs at most twice
// what rebuilding it at once would have; and γ merely moving rebuilds
// nothing: in a slip's small steps H ∝ γ is small and any old LU contracts
// fast (rebuilding on every 20 % change of γ spent half of Fig. 9's block
// slip in LUs of the 896² matrix).
LatticeStageSolver::StepSolve LatticeStageSolver::newton_step(bool krylov, double norm,
                                                              double lu_in_krylov,
                                                              Eigen::Index max_krylov) {
  if (matrix_free_) {
    near_field_step(norm);
    return StepSolve::krylov;
  }
  StepSolve solved = StepSolve::kept_lu;
  if (!jacobian_lu_) {
    factorize_jacobian();
    solved = StepSolve::fresh_lu;  // (never by GMRES: its own step is Newton's)
  } else if (krylov) {
    const double relative = std::clamp(kForcing * kTolerance / norm, kMinForcing, kMaxForcing);
    const long before = krylov_iterations_;
    if (krylov_step(relative, max_krylov)) {
      stale_krylov_ += static_cast<double>(krylov_iterations_ - before - 1);
      if (stale_krylov_ > lu_in_krylov) jacobian_lu_.reset();
      return StepSolve::krylov;
    }
    factorize_jacobian();  // too stale to precondition
    solved = StepSolve::fresh_lu;
  }
  step_ = solve_with_lu(-residual_);
  return solved;
}

long LatticeStageSolver::solve_contacts(std::span<const double> predictor,
                                        std::span<const double> weights) {
  const LuPrice lu_price(sites_);
  const double gamma_self = gamma_ * self_green_;
  for (std::size_t i = 0; i < sites_; ++i)
    predicted_speed_[i] = std::hypot(predictor[site_w_[i]], predictor[site_w_[i] + 1]);
  for (std::size_t i = 0; i < sites_; ++i)
    for (int k = 0; k < 2; ++k) newton_weight_(2 * i + k) = weights[site_w_[i] + k];

  // F(β) and its weighted max norm; Σ(β) into sigma_, ∂Σ/∂β into stages_.
  auto stage = [&](const Eigen::VectorXd& beta, std::size_t i) {
    if (prescribed_[i]) {
      // s − γ ḡ (p + q s) = β with p, q given: s = (β + γ ḡ p)/(1 − γ ḡ q).
      const auto& p = prescribed_acceleration_[i];
      const double gain = 1.0 / (1.0 - gamma_self * prescribed_rate_[i]);
      if (!(gain > 0.0))
        throw std::logic_error("a prescribed site's rate exceeds 1/(gamma g) (prescribe)");
      stages_[i].s = {gain * (beta(2 * i) + gamma_self * p[0]),
                      gain * (beta(2 * i + 1) + gamma_self * p[1])};
      stages_[i].ds_db = {gain, 0.0, 0.0, gain};
      stages_[i].iterations = 0;
      sigma_(2 * i) = stages_[i].s[0];
      sigma_(2 * i + 1) = stages_[i].s[1];
      return;
    }
    stages_[i] = system_.contact_set().site_stage(i, gamma_self, {beta(2 * i), beta(2 * i + 1)},
                                                  predicted_speed_[i], true);
    sigma_(2 * i) = stages_[i].s[0];
    sigma_(2 * i + 1) = stages_[i].s[1];
  };
  auto evaluate = [&](const Eigen::VectorXd& beta) {
    parallel_for(loop_threads(), static_cast<std::int64_t>(sites_),
                 [&](std::int64_t i) { stage(beta, static_cast<std::size_t>(i)); });
    trial_force_ = sigma_ - beta;
    apply_coupling(trial_force_, product_);
    residual_ = beta - free_speed_ - product_;
    double norm = 0.0;
    for (std::size_t i = 0; i < sites_; ++i)
      for (int k = 0; k < 2; ++k)
        norm = std::max(norm, std::abs(residual_(2 * i + k)) * weights[site_w_[i] + k]);
    return norm;
  };
  // β + f δ into trial_, f halved while the residual grows; returns ‖F(trial_)‖.
  auto backtrack = [&](double norm) {
    double fraction = 1.0, trial_norm = 0.0;
    for (;;) {
      trial_ = beta_ + fraction * step_;
      trial_norm = evaluate(trial_);
      if (trial_norm < norm || fraction < kMinStepFraction) return trial_norm;
      fraction *= 0.5;
    }
  };

  // Start from the predictor's contact forces: β = s0 + γ ḡ H a_c(s_pred).
  for (std::size_t i = 0; i < sites_; ++i) {
    const std::array<double, 2> s{predictor[site_w_[i]], predictor[site_w_[i] + 1]};
    const auto a =
        prescribed_[i]
            ? std::array<double, 2>{prescribed_acceleration_[i][0] + prescribed_rate_[i] * s[0],
                                    prescribed_acceleration_[i][1] + prescribed_rate_[i] * s[1]}
            : system_.contact_set().site_acceleration(i, s);
    trial_(2 * i) = gamma_self * a[0];
    trial_(2 * i + 1) = gamma_self * a[1];
  }
  apply_coupling(trial_, product_);
  beta_ = free_speed_ + product_;
  double norm = evaluate(beta_);
  // The steps' policy: with the kept LU (modified Newton) until its steps go
  // wrong (no decrease) or slow (converging would cost more than an LU),
  // then Newton's by GMRES (`krylov`) until an LU is built again.
  bool krylov = false;
  for (int it = 0; it < kMaxIterations; ++it) {
    if (!std::isfinite(norm)) break;
    if (norm <= kTolerance) return it;
    const StepSolve solved = newton_step(krylov, norm, lu_price.krylov, lu_price.max_krylov);
    krylov = solved == StepSolve::krylov;
    const double trial_norm = backtrack(norm);
    if (!(trial_norm < norm)) {
      if (solved == StepSolve::kept_lu) {  // the old LU's step: take Newton's from here
        evaluate(beta_);
        krylov = true;
        continue;
      }
      if (norm <= kStagnated) {  // rounding, not divergence
        evaluate(beta_);
        return it + 1;
      }
      // Newton's own step and still no decrease: take the damped step
      // anyway; Newton's steps continue from it.
      krylov = true;
    } else if (solved == StepSolve::kept_lu && trial_norm > kTolerance &&
               too_slow(norm, trial_norm, it, lu_price)) {
      krylov = true;  // a slow contraction with the old LU: Newton's steps from here
    }
    beta_ = trial_;
    norm = trial_norm;
  }
  throw StageNotConverged("the contacts' coupled stage equations did not converge");
}

}  // namespace stickslip
