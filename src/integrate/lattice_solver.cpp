#include "stickslip/integrate/lattice_solver.hpp"

#include <fftw3.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <mutex>
#include <stdexcept>

#include "stickslip/model/parallel_for.hpp"

namespace stickslip {
namespace {

using Block = Eigen::Matrix3cd;
using BlockMap = Eigen::Map<Block>;
using ConstBlockMap = Eigen::Map<const Block>;
using Vec3Map = Eigen::Map<Eigen::Vector3cd>;

fftw_complex* as_fftw(std::complex<double>* p) {
  return reinterpret_cast<fftw_complex*>(p);
}

// FFTW's planner (making and destroying plans) is not thread-safe; only
// executing a plan is. Runs in threads of one process (the Python module
// releases the GIL) take turns here.
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

// FFTW plans, destroyed with the solver. Planned with FFTW_ESTIMATE: the same
// algorithm on every run, so results are reproducible bit for bit.
struct LatticeSolver::Plans {
  // The velocity field's transforms, one plan per group of layers (their
  // three components each), so the groups can go to the run's threads.
  std::vector<fftw_plan> forward, backward;
  fftw_plan green = nullptr, surface_forward = nullptr, surface_backward = nullptr;
  ~Plans() {
    const std::lock_guard lock(planner_mutex());
    for (fftw_plan p : forward) fftw_destroy_plan(p);
    for (fftw_plan p : backward) fftw_destroy_plan(p);
    for (fftw_plan p : {green, surface_forward, surface_backward})
      if (p) fftw_destroy_plan(p);
  }
};

LatticeSolver::LatticeSolver(const System& system)
    : nx_(system.nx()),
      ny_(system.ny()),
      nz_(system.nz()),
      threads_(system.threads()),
      modes_(std::int64_t{nx_ / 2 + 1} * ny_),
      real_(static_cast<std::size_t>(3 * system.num_nodes())),
      spectrum_(static_cast<std::size_t>(3 * nz_ * modes_)),
      plans_(std::make_unique<Plans>()) {
  const int nkx = nx_ / 2 + 1;
  // The velocity field: index 3 (ix + Nx (iy + Ny iz)) + k; one 2D transform
  // over (iy, ix) per layer and component. Its spectrum: index
  // k + 3 (iz + Nz (kx + nkx iy)).
  std::unique_lock lock(planner_mutex());
  const fftw_iodim real_dims[2] = {{ny_, 3 * nx_, 3 * nz_ * nkx}, {nx_, 3, 3 * nz_}};
  const fftw_iodim spec_dims[2] = {{ny_, 3 * nz_ * nkx, 3 * nx_}, {nx_, 3 * nz_, 3}};
  // One plan per group of layers: a layer each where layers are wide enough
  // to pay for going to threads, all layers in one plan below that (a
  // 6×6×4 pair ran 25 % slower a step with a plan per layer). Chosen by the
  // lattice alone, so the arithmetic does not depend on the thread count.
  layers_per_group_ = std::int64_t{nx_} * ny_ >= kLayeredFftPoints ? 1 : nz_;
  const fftw_iodim many[2] = {{layers_per_group_, 3 * nx_ * ny_, 3}, {3, 1, 1}};
  const fftw_iodim spec_many[2] = {{layers_per_group_, 3, 3 * nx_ * ny_}, {3, 1, 1}};
  for (int iz = 0; iz < nz_; iz += layers_per_group_) {
    double* group = real_.data() + std::size_t{3} * nx_ * ny_ * iz;
    fftw_complex* group_spectrum = as_fftw(spectrum_.data() + 3 * iz);
    if (fftw_plan p =
            fftw_plan_guru_dft_r2c(2, real_dims, 2, many, group, group_spectrum, FFTW_ESTIMATE))
      plans_->forward.push_back(p);
    if (fftw_plan p = fftw_plan_guru_dft_c2r(2, spec_dims, 2, spec_many, group_spectrum, group,
                                             FFTW_ESTIMATE))
      plans_->backward.push_back(p);
  }
  // The Green's function: four fields (a, b), spectrum [mode][a b] → [a b][iy][ix].
  green_.resize(static_cast<std::size_t>(4 * nx_ * ny_));
  green_spectrum_.resize(static_cast<std::size_t>(4 * modes_));
  const fftw_iodim green_dims[2] = {{ny_, 4 * nkx, nx_}, {nx_, 4, 1}};
  const fftw_iodim green_many[1] = {{4, 1, nx_ * ny_}};
  plans_->green = fftw_plan_guru_dft_c2r(
      2, green_dims, 1, green_many, as_fftw(green_spectrum_.data()), green_.data(), FFTW_ESTIMATE);
  // A bottom-layer field of two components, [a][iy][ix] ↔ [a][mode].
  surface_green_.resize(green_spectrum_.size());
  surface_spectrum_.resize(static_cast<std::size_t>(2 * modes_));
  surface_field_.resize(static_cast<std::size_t>(2 * nx_ * ny_));
  const fftw_iodim surface_real[2] = {{ny_, nx_, nkx}, {nx_, 1, 1}};
  const fftw_iodim surface_real_many[1] = {{2, nx_ * ny_, static_cast<int>(modes_)}};
  plans_->surface_forward =
      fftw_plan_guru_dft_r2c(2, surface_real, 1, surface_real_many, surface_field_.data(),
                             as_fftw(surface_spectrum_.data()), FFTW_ESTIMATE);
  const fftw_iodim surface_spec[2] = {{ny_, nkx, nx_}, {nx_, 1, 1}};
  const fftw_iodim surface_spec_many[1] = {{2, static_cast<int>(modes_), nx_ * ny_}};
  plans_->surface_backward = fftw_plan_guru_dft_c2r(2, surface_spec, 1, surface_spec_many,
                                                    as_fftw(surface_spectrum_.data()),
                                                    surface_field_.data(), FFTW_ESTIMATE);
  lock.unlock();
  const auto groups = static_cast<std::size_t>(nz_ / layers_per_group_);
  if (plans_->forward.size() != groups || plans_->backward.size() != groups || !plans_->green ||
      !plans_->surface_forward || !plans_->surface_backward)
    throw std::runtime_error("FFTW could not plan the lattice transforms");

  const std::size_t blocks = static_cast<std::size_t>(9 * nz_ * modes_);
  for (auto* v : {&k_diag_, &k_up_, &c_diag_, &c_up_, &s_inv_, &upper_, &multiplier_})
    v->assign(blocks, Complex{});
  probe(system);
}

LatticeSolver::~LatticeSolver() = default;

// Column (jz, l) of K̂(q) and Ĉ(q) for every q at once: the lattice's response
// to a unit displacement (velocity) of node (0, 0, jz) along l, less its
// response to nothing (the plate's forcing), transformed.
void LatticeSolver::probe(const System& system) {
  const std::size_t n3 = real_.size();
  std::vector<double> zero(n3, 0.0), unit(n3, 0.0), base(n3), response(n3);
  system.lattice_accelerations(0.0, zero, zero, base);
  double scale = 0.0;  // the largest entry seen, for the check below
  for (int operator_index = 0; operator_index < 2; ++operator_index) {
    const bool stiffness = operator_index == 0;
    auto& diag = stiffness ? k_diag_ : c_diag_;
    auto& up = stiffness ? k_up_ : c_up_;
    for (int jz = 0; jz < nz_; ++jz)
      for (int l = 0; l < 3; ++l) {
        const std::int64_t at = system.u_index(system.node(0, 0, jz), l);
        unit[at] = 1.0;
        system.lattice_accelerations(0.0, stiffness ? unit : zero, stiffness ? zero : unit,
                                     response);
        unit[at] = 0.0;
        // K e = −(a(e) − a(0)): the accelerations are −K u − C w + forcing.
        for (std::size_t r = 0; r < n3; ++r) real_[r] = base[r] - response[r];
        transform_forward();
        for (std::int64_t m = 0; m < modes_; ++m)
          for (int iz = 0; iz < nz_; ++iz)
            for (int k = 0; k < 3; ++k) {
              const Complex v = spectrum_[k + 3 * (iz + nz_ * m)];
              scale = std::max(scale, std::abs(v));
              const std::size_t slot = 9 * (iz + nz_ * m) + k + 3 * l;
              if (iz == jz) {
                diag[slot] = v;
              } else if (iz + 1 == jz) {
                up[slot] = v;  // block (iz, iz + 1)
              } else if (iz != jz + 1 && std::abs(v) > 1e-12 * scale) {
                throw std::logic_error(
                    "the lattice operator couples layers more than one apart: the block-"
                    "tridiagonal lattice solver does not apply");
              }
            }
      }
  }
}

void LatticeSolver::set_gamma(double gamma) {
  if (gamma == gamma_) return;
  gamma_ = gamma;
  ++factorizations_;
  // Per mode: its factorization, then the Green's function, column b of
  // M̂(q)⁻¹ at the bottom layer. Modes are independent: any thread may take one.
  for_each_mode([&](std::int64_t m) {
    factorize_mode(m);
    thread_local std::vector<Complex> x;  // no allocation per mode (was 1.4 % of a slip)
    x.resize(static_cast<std::size_t>(3 * nz_));
    for (int b = 0; b < 2; ++b) {
      std::fill(x.begin(), x.end(), Complex{});
      x[b] = 1.0;
      solve_mode(m, x.data());
      for (int a = 0; a < 2; ++a) green_spectrum_[4 * m + 2 * a + b] = x[a];
    }
  });
  const double norm = 1.0 / (static_cast<double>(nx_) * ny_);
  for (std::size_t i = 0; i < green_spectrum_.size(); ++i)
    surface_green_[i] = green_spectrum_[i] * norm;
  fftw_execute(plans_->green);  // overwrites green_spectrum_
  for (double& g : green_) g *= norm;
}

void LatticeSolver::convolve_surface() {
  if (gamma_ < 0.0) throw std::logic_error("LatticeSolver::convolve_surface before set_gamma");
  fftw_execute(plans_->surface_forward);
  Complex* fx = surface_spectrum_.data();
  Complex* fy = fx + modes_;
  for (std::int64_t m = 0; m < modes_; ++m) {
    const Complex* g = &surface_green_[4 * m];
    const Complex x = fx[m], y = fy[m];
    fx[m] = g[0] * x + g[1] * y;
    fy[m] = g[2] * x + g[3] * y;
  }
  fftw_execute(plans_->surface_backward);  // overwrites the spectrum, scratch
}

// Block LDLᴴ of the Hermitian block-tridiagonal M̂ = I + γ Ĉ + γ² K̂:
//   S_0 = A_0,  S_i = A_i − W_{i−1} B_{i−1},  W_i = B_iᴴ S_i⁻¹,
// with A_i the diagonal blocks and B_i the blocks (i, i+1). M is symmetric
// positive definite (M ≥ I), so no pivoting is needed.
void LatticeSolver::factorize_mode(std::int64_t m) {
  const double g = gamma_, g2 = gamma_ * gamma_;
  for (int iz = 0; iz < nz_; ++iz) {
    const std::size_t at = 9 * (iz + nz_ * m);
    Block a =
        Block::Identity() + g * ConstBlockMap(&c_diag_[at]) + g2 * ConstBlockMap(&k_diag_[at]);
    if (iz > 0) {
      const std::size_t below = at - 9;
      a -= ConstBlockMap(&multiplier_[below]) * ConstBlockMap(&upper_[below]);
    }
    BlockMap s_inv(&s_inv_[at]);
    s_inv = a.inverse();
    if (iz + 1 < nz_) {
      BlockMap b(&upper_[at]);
      b = g * ConstBlockMap(&c_up_[at]) + g2 * ConstBlockMap(&k_up_[at]);
      BlockMap multiplier(&multiplier_[at]);
      multiplier = b.adjoint() * s_inv;
    }
  }
}

void LatticeSolver::solve_mode(std::int64_t m, Complex* x) const {
  const std::size_t first = 9 * nz_ * m;
  for (int iz = 1; iz < nz_; ++iz)
    Vec3Map(x + 3 * iz) -=
        ConstBlockMap(&multiplier_[first + 9 * (iz - 1)]) * Vec3Map(x + 3 * (iz - 1));
  for (int iz = nz_ - 1; iz >= 0; --iz) {
    Eigen::Vector3cd y = Vec3Map(x + 3 * iz);
    if (iz + 1 < nz_) y -= ConstBlockMap(&upper_[first + 9 * iz]) * Vec3Map(x + 3 * (iz + 1));
    Vec3Map(x + 3 * iz) = ConstBlockMap(&s_inv_[first + 9 * iz]) * y;
  }
}

template <class PerMode>
void LatticeSolver::for_each_mode(PerMode&& per_mode) const {
  parallel_for(threads_, modes_, per_mode);
}

// Group by group of layers (plans_), each on one thread (its plan, its part
// of real_ and of spectrum_), with the copy in (`from`) or out (`to`) of it.
void LatticeSolver::transform_forward(const double* from) {
  const std::size_t group = std::size_t{3} * nx_ * ny_ * layers_per_group_;
  parallel_for(threads_, static_cast<std::int64_t>(plans_->forward.size()), [&](std::int64_t g) {
    if (from) std::copy_n(from + group * g, group, real_.data() + group * g);
    fftw_execute(plans_->forward[static_cast<std::size_t>(g)]);
  });
}

void LatticeSolver::transform_backward(double* to) {
  const std::size_t group = std::size_t{3} * nx_ * ny_ * layers_per_group_;
  const double norm = 1.0 / (static_cast<double>(nx_) * ny_);
  parallel_for(threads_, static_cast<std::int64_t>(plans_->backward.size()), [&](std::int64_t g) {
    fftw_execute(plans_->backward[static_cast<std::size_t>(g)]);
    double* v = real_.data() + group * g;
    for (std::size_t i = 0; i < group; ++i) v[i] *= norm;
    if (to) std::copy_n(v, group, to + group * g);
  });
}

void LatticeSolver::solve(std::span<const double> r, std::span<double> w) {
  if (gamma_ < 0.0) throw std::logic_error("LatticeSolver::solve before set_gamma");
  ++solves_;
  transform_forward(r.data());
  for_each_mode([&](std::int64_t m) { solve_mode(m, &spectrum_[3 * nz_ * m]); });
  transform_backward(w.data());
}

double LatticeSolver::green(int dx, int dy, int a, int b) const {
  return green_wrapped(wrapped_offset(dx, dy), a, b);
}

}  // namespace stickslip
