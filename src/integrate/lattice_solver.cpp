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

// A plan without buffering where FFTW has one: its buffered plans allocate
// their buffers at every execution (malloc ~7 % of a 30x30x10 run);
// unbuffered, a 30x30x10 solve took 335 instead of 405 µs (bench/micro.cpp,
// lattice_solve). Some shapes have none (a 33-wide layer): those are buffered.
template <class Planner>
fftw_plan plan_unbuffered_if_possible(Planner&& planner) {
  if (fftw_plan p = planner(FFTW_ESTIMATE | FFTW_NO_BUFFERING)) return p;
  return planner(FFTW_ESTIMATE);
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

LatticeSolver::LatticeSolver(const System& system, std::shared_ptr<const ThreadBudget> threads)
    : threads_(std::move(threads)),
      nx_(system.nx()),
      ny_(system.ny()),
      nz_(system.nz()),
      modes_(std::int64_t{nx_ / 2 + 1} * ny_),
      real_(static_cast<std::size_t>(3 * system.num_nodes())),
      spectrum_(static_cast<std::size_t>(3 * nz_ * modes_)),
      plans_(std::make_unique<Plans>()) {
  const int nkx = nx_ / 2 + 1;
  // The velocity field in planes, [iz][k][iy][ix] (transform_forward
  // gathers it from the state's nodes), and its half spectrum [iz][k][mode]:
  // 3 Nz contiguous 2D transforms of one layout in and out, which FFTW runs
  // without buffers of its own. With the state's interleaved components and a
  // spectrum laid out mode by mode, it copied through buffers it allocated at
  // every execution (malloc and copies ~12 % of a 30x30x10 run at θ = 0.04).
  std::unique_lock lock(planner_mutex());
  // One plan per group of layers: a layer each where layers are wide enough
  // to pay for going to threads, all layers in one plan below that (a
  // 6×6×4 pair ran 25 % slower a step with a plan per layer). Chosen by the
  // lattice alone, so the arithmetic does not depend on the thread count.
  layers_per_group_ = std::int64_t{nx_} * ny_ >= kLayeredFftPoints ? 1 : nz_;
  const int size[2] = {ny_, nx_};
  const int fields = 3 * layers_per_group_, plane = nx_ * ny_;
  const int spectral_plane = static_cast<int>(modes_);
  for (int iz = 0; iz < nz_; iz += layers_per_group_) {
    double* group = real_.data() + std::size_t{3} * plane * iz;
    fftw_complex* group_spectrum = as_fftw(spectrum_.data() + std::size_t{3} * modes_ * iz);
    if (fftw_plan p = plan_unbuffered_if_possible([&](unsigned flags) {
          return fftw_plan_many_dft_r2c(2, size, fields, group, nullptr, 1, plane, group_spectrum,
                                        nullptr, 1, spectral_plane, flags);
        }))
      plans_->forward.push_back(p);
    if (fftw_plan p = plan_unbuffered_if_possible([&](unsigned flags) {
          return fftw_plan_many_dft_c2r(2, size, fields, group_spectrum, nullptr, 1, spectral_plane,
                                        group, nullptr, 1, plane, flags);
        }))
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
  plans_->surface_forward = plan_unbuffered_if_possible([&](unsigned flags) {
    return fftw_plan_guru_dft_r2c(2, surface_real, 1, surface_real_many, surface_field_.data(),
                                  as_fftw(surface_spectrum_.data()), flags);
  });
  const fftw_iodim surface_spec[2] = {{ny_, nkx, nx_}, {nx_, 1, 1}};
  const fftw_iodim surface_spec_many[1] = {{2, static_cast<int>(modes_), nx_ * ny_}};
  plans_->surface_backward = plan_unbuffered_if_possible([&](unsigned flags) {
    return fftw_plan_guru_dft_c2r(2, surface_spec, 1, surface_spec_many,
                                  as_fftw(surface_spectrum_.data()), surface_field_.data(), flags);
  });
  lock.unlock();
  const auto groups = static_cast<std::size_t>(nz_ / layers_per_group_);
  if (plans_->forward.size() != groups || plans_->backward.size() != groups || !plans_->green ||
      !plans_->surface_forward || !plans_->surface_backward)
    throw std::runtime_error("FFTW could not plan the lattice transforms");

  const std::size_t blocks = static_cast<std::size_t>(9 * nz_ * modes_);
  for (auto* v : {&k_diag_, &k_up_, &c_diag_, &c_up_, &s_inv_, &upper_, &multiplier_})
    v->assign(blocks, Complex{});
  surface_response_.assign(static_cast<std::size_t>(2 * 3 * nz_ * modes_), Complex{});
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
        for (std::size_t r = 0; r < n3; ++r) response[r] = base[r] - response[r];
        transform_forward(response.data());
        for (std::int64_t m = 0; m < modes_; ++m)
          for (int iz = 0; iz < nz_; ++iz)
            for (int k = 0; k < 3; ++k) {
              const Complex v = spectrum_[spectral_index(m, iz, k)];
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
  // Per mode: its factorization, then column b of M̂(q)⁻¹ at the bottom
  // layer's in-plane component b: the whole lattice's response to a force
  // there (add_surface_source), whose bottom entries are the Green's
  // function. Modes are independent: any thread may take one.
  const std::size_t column = static_cast<std::size_t>(3 * nz_);
  for_each_mode([&](std::int64_t m) {
    factorize_mode(m);
    for (int b = 0; b < 2; ++b) {
      Complex* x = &surface_response_[(2 * static_cast<std::size_t>(m) + b) * column];
      std::fill(x, x + column, Complex{});
      x[b] = 1.0;
      solve_mode(m, x);
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
  parallel_for(loop_threads(), modes_, per_mode);
}

// Group by group of layers (plans_), each on one thread (its plan, its part
// of real_ and of spectrum_), with the state's interleaved components
// gathered into planes (`from`) or scattered back from them (`to`).
void LatticeSolver::transform_forward(const double* from) {
  const std::int64_t plane = std::int64_t{nx_} * ny_;
  parallel_for(
      loop_threads(), static_cast<std::int64_t>(plans_->forward.size()), [&](std::int64_t g) {
        if (from)
          for (std::int64_t iz = g * layers_per_group_; iz < (g + 1) * layers_per_group_; ++iz) {
            const double* nodes = from + 3 * plane * iz;
            double* planes = real_.data() + 3 * plane * iz;
            for (std::int64_t p = 0; p < plane; ++p)
              for (int k = 0; k < 3; ++k) planes[k * plane + p] = nodes[3 * p + k];
          }
        fftw_execute(plans_->forward[static_cast<std::size_t>(g)]);
      });
}

void LatticeSolver::transform_backward(double* to) {
  const std::int64_t plane = std::int64_t{nx_} * ny_;
  const double norm = 1.0 / static_cast<double>(plane);
  parallel_for(
      loop_threads(), static_cast<std::int64_t>(plans_->backward.size()), [&](std::int64_t g) {
        fftw_execute(plans_->backward[static_cast<std::size_t>(g)]);
        for (std::int64_t iz = g * layers_per_group_; iz < (g + 1) * layers_per_group_; ++iz) {
          double* nodes = to + 3 * plane * iz;
          const double* planes = real_.data() + 3 * plane * iz;
          for (std::int64_t p = 0; p < plane; ++p)
            for (int k = 0; k < 3; ++k) nodes[3 * p + k] = norm * planes[k * plane + p];
        }
      });
}

// Each mode's 3 Nz unknowns lie `modes_` apart in the spectrum: gathered into
// a contiguous vector for the solve and scattered back.
void LatticeSolver::solve_held() {
  const std::size_t column = static_cast<std::size_t>(3 * nz_);
  for_each_mode([&](std::int64_t m) {
    thread_local std::vector<Complex> x;  // no allocation per mode
    x.resize(column);
    const Complex* in = spectrum_.data() + m;
    for (std::size_t i = 0; i < column; ++i) x[i] = in[i * modes_];
    solve_mode(m, x.data());
    Complex* out = spectrum_.data() + m;
    for (std::size_t i = 0; i < column; ++i) out[i * modes_] = x[i];
  });
}

void LatticeSolver::begin_solve(std::span<const double> r) {
  if (gamma_ < 0.0) throw std::logic_error("LatticeSolver::solve before set_gamma");
  ++solves_;
  transform_forward(r.data());
  solve_held();
}

// The bottom layer's in-plane components are the first two planes of the
// held spectrum, laid out as surface_spectrum_ is.
void LatticeSolver::held_surface_velocity() {
  std::copy_n(spectrum_.begin(), surface_spectrum_.size(), surface_spectrum_.begin());
  fftw_execute(plans_->surface_backward);
  const double norm = 1.0 / (static_cast<double>(nx_) * ny_);
  for (double& v : surface_field_) v *= norm;
}

// M⁻¹ Pᵀ f in spectrum: the transform of f (nonzero on the bottom layer's
// in-plane components only) times the columns of M̂⁻¹ at those components,
// kept from set_gamma; no transform of the whole lattice and no solve.
void LatticeSolver::add_surface_source() {
  fftw_execute(plans_->surface_forward);
  const std::size_t column = static_cast<std::size_t>(3 * nz_);
  for_each_mode([&](std::int64_t m) {
    const Complex fx = surface_spectrum_[static_cast<std::size_t>(m)];
    const Complex fy = surface_spectrum_[static_cast<std::size_t>(modes_ + m)];
    const Complex* x = &surface_response_[2 * static_cast<std::size_t>(m) * column];
    const Complex* y = x + column;
    Complex* out = spectrum_.data() + m;
    for (std::size_t i = 0; i < column; ++i) out[i * modes_] += x[i] * fx + y[i] * fy;
  });
}

void LatticeSolver::finish_solve(std::span<double> w) {
  transform_backward(w.data());
}

void LatticeSolver::solve(std::span<const double> r, std::span<double> w) {
  begin_solve(r);
  finish_solve(w);
}

double LatticeSolver::green(int dx, int dy, int a, int b) const {
  return green_wrapped(wrapped_offset(dx, dy), a, b);
}

}  // namespace stickslip
