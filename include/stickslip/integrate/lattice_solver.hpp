#pragma once
// Exact solves with the lattice part of an implicit stage, by FFT in x and y.
//
// An implicit stage z − γ f(z) = b with the lattice's f (u' = w,
// w' = −K u − C w + forcing; MODEL.md §3–5) reduces, after u = b_u + γ w, to
//     M(γ) w = r,   M(γ) = I + γ C + γ² K,
// which is symmetric positive definite. K and C are constant and invariant
// under translations in x and y (periodic), so a 2D real FFT over (x, y)
// splits M into Nx·(Ny/2+1) independent Hermitian systems of 3 Nz unknowns,
// block-tridiagonal along z (faces and cells reach one layer up or down).
// Each is factorized once per γ (block LDLᴴ with 3×3 blocks) and reused.
//
// The blocks are read off the System by probing: the response of
// System::lattice_accelerations to a unit displacement (for K) or velocity
// (for C) of one node in each layer, Fourier-transformed. So the solver never
// copies the stencil, and small lattices (Nx = 1, 2: faces that meet their
// own periodic image) come out as the System defines them.
//
// The bottom layer's Green's function (M⁻¹ between the in-plane velocities of
// two bottom nodes) depends only on their offset; one inverse FFT per γ gives
// it for every offset (`green`), and multiplying by its spectrum applies it
// to a whole in-plane field of the bottom layer at FFT cost
// (`convolve_surface`): what the contacts' stage solve multiplies by most.

#include <complex>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "stickslip/model/parallel_for.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

class LatticeSolver {
 public:
  // Its loops run on `threads` (the run's budget); none: one thread.
  explicit LatticeSolver(const System& system,
                         std::shared_ptr<const ThreadBudget> threads = nullptr);
  ~LatticeSolver();
  LatticeSolver(const LatticeSolver&) = delete;
  LatticeSolver& operator=(const LatticeSolver&) = delete;

  // Factorizes M(γ) and computes the bottom layer's Green's function, unless
  // γ is the one already factorized.
  void set_gamma(double gamma);
  double gamma() const { return gamma_; }

  // w = M(γ)⁻¹ r for the velocity block (3N values, the state's node order).
  // r and w may be the same span.
  void solve(std::span<const double> r, std::span<double> w);

  // The same solve in parts, for a stage whose forces on the bottom layer
  // are known only from the solution (LatticeStageSolver::solve):
  //     w = M⁻¹ r + M⁻¹ Pᵀ f
  // at the cost of one solve, one transform each way of the lattice, where
  // two solves cost two. begin_solve holds M⁻¹ r (in spectrum);
  // held_surface_velocity writes its bottom layer's in-plane components into
  // surface_field(); add_surface_source adds M⁻¹ Pᵀ f for the in-plane
  // forces f in surface_field() (which it leaves as scratch); finish_solve
  // writes the held solution to w.
  void begin_solve(std::span<const double> r);
  void held_surface_velocity();
  void add_surface_source();
  void finish_solve(std::span<double> w);

  // (M(γ)⁻¹) between in-plane component a of bottom node (ix + dx, iy + dy)
  // and component b of bottom node (ix, iy), for any (ix, iy); a, b ∈ {0, 1}
  // (x, y). Offsets wrap periodically.
  double green(int dx, int dy, int a, int b) const;
  // The same for an offset wrapped once by wrapped_offset: no integer
  // division, for the N_c² lookups at every γ.
  double green_wrapped(std::int64_t offset, int a, int b) const {
    return green_[static_cast<std::size_t>((2 * a + b) * std::int64_t{nx_} * ny_ + offset)];
  }
  // (dx, dy) wrapped periodically into [0, Nx) × [0, Ny), as dx + Nx dy.
  std::int64_t wrapped_offset(int dx, int dy) const {
    return ((dx % nx_) + nx_) % nx_ + std::int64_t{nx_} * (((dy % ny_) + ny_) % ny_);
  }

  // A field on the bottom layer's in-plane components, 2 Nx Ny values laid
  // out [component][iy][ix] (component b of node (ix, iy) at
  // b Nx Ny + ix + Nx iy), and its convolution with the Green's function in
  // place: field_a(x) ← Σ_{b, y} green(x − y, a, b) field_b(y), the in-plane
  // velocities that in-plane forces `field` give through M(γ)⁻¹. The same
  // sum as green's, by FFT.
  std::span<double> surface_field() { return surface_field_; }
  void convolve_surface();

  long factorizations() const { return factorizations_; }
  long solves() const { return solves_; }

 private:
  using Complex = std::complex<double>;
  struct Plans;

  void probe(const System& system);
  void factorize_mode(std::int64_t m);
  void solve_mode(std::int64_t m, Complex* x) const;
  // per_mode(m) for every mode, on the run's loop threads.
  template <class PerMode>
  void for_each_mode(PerMode&& per_mode) const;
  // `from` (3N values, the state's node order) → real_ → spectrum_.
  void transform_forward(const double* from);
  // spectrum_ → real_ → `to`, scaled by 1/(Nx Ny).
  void transform_backward(double* to);
  // The held spectrum ← M̂⁻¹ times it, mode by mode.
  void solve_held();
  // Where component k of layer iz of mode m lies in spectrum_.
  std::size_t spectral_index(std::int64_t m, int iz, int k) const {
    return static_cast<std::size_t>((3 * iz + k) * modes_ + m);
  }

  // Layers of at least this many nodes get an FFT plan each (threads take
  // them layer by layer); smaller ones share one plan.
  static constexpr std::int64_t kLayeredFftPoints = 1024;
  int loop_threads() const { return threads_ ? threads_->now() : 1; }
  std::shared_ptr<const ThreadBudget> threads_;  // the run's; none: one thread
  int nx_, ny_, nz_;
  int layers_per_group_ = 1;  // of the velocity field's FFT plans
  std::int64_t modes_;        // Nx/2+1 times Ny (the half spectrum of a real 2D field)
  double gamma_ = -1.0;
  long factorizations_ = 0, solves_ = 0;
  // Per mode and layer, 3×3 complex blocks (column-major, 9 values each):
  // K̂ and Ĉ on the diagonal (iz, iz) and above it (iz, iz+1).
  std::vector<Complex> k_diag_, k_up_, c_diag_, c_up_;
  // The factorization of M̂ per mode and layer: S_iz⁻¹, the upper block B_iz
  // of M̂, and the multiplier W_iz = B_izᴴ S_iz⁻¹.
  std::vector<Complex> s_inv_, upper_, multiplier_;
  std::vector<double> green_;            // [a][b][iy][ix]
  std::vector<Complex> green_spectrum_;  // [mode][a][b]
  // The same for convolve_surface, kept (the Green's transform overwrites
  // green_spectrum_) and scaled by 1/(Nx Ny); its field's half spectrum.
  std::vector<Complex> surface_green_;     // [mode][a][b]
  std::vector<Complex> surface_spectrum_;  // [component][mode]
  std::vector<double> surface_field_;
  // Per mode, the columns of M̂⁻¹ at the bottom layer's x and y: [mode][b][3 Nz].
  std::vector<Complex> surface_response_;
  // FFT buffers: the velocity field (3N reals) in planes [layer][component]
  // [iy][ix] and its half spectrum [layer][component][mode].
  std::vector<double> real_;
  std::vector<Complex> spectrum_;
  std::unique_ptr<Plans> plans_;
};

}  // namespace stickslip
