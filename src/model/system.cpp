#include "stickslip/model/system.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "stickslip/model/parallel_for.hpp"

namespace stickslip {
namespace {

// The eight corners of a cell, as offsets (dx, dy, dz) ∈ {0,1}³, and the sign
// with which each corner's displacement enters D_c along each axis: +1 for the
// "hi" end of an edge, −1 for the "lo" end (MODEL.md §3).
struct Corner {
  int dx, dy, dz;
  double sx, sy, sz;
};
constexpr std::array<Corner, 8> kCorners = {{
    {0, 0, 0, -1, -1, -1},
    {1, 0, 0, +1, -1, -1},
    {0, 1, 0, -1, +1, -1},
    {1, 1, 0, +1, +1, -1},
    {0, 0, 1, -1, -1, +1},
    {1, 0, 1, +1, -1, +1},
    {0, 1, 1, -1, +1, +1},
    {1, 1, 1, +1, +1, +1},
}};

// Σ_corners s·u of a cell, 4 D_c (MODEL.md §3): the forces and the energy
// both read the cell's strain from here.
inline double corner_sum(const double* u, const std::int64_t (&corner)[8]) {
  double d = 0.0;
  for (int c = 0; c < 8; ++c) {
    const Corner& k = kCorners[c];
    const double* uc = u + 3 * corner[c];
    d += k.sx * uc[0] + k.sy * uc[1] + k.sz * uc[2];
  }
  return d;
}

}  // namespace

template <class Face>
void System::faces(int iz, Face&& face) const {
  const std::int64_t layer = std::int64_t{nx_} * ny_;
  for (int iy = 0; iy < ny_; ++iy)
    for (int ix = 0; ix < nx_; ++ix) {
      const std::int64_t i = node(ix, iy, iz);
      face(i, node(x_next_[ix], iy, iz));
      face(i, node(ix, y_next_[iy], iz));
      if (iz + 1 < nz_) face(i, i + layer);
    }
}

template <class Cell>
void System::cells(int iz, Cell&& cell) const {
  if (iz + 1 >= nz_) return;
  for (int iy = 0; iy < ny_; ++iy)
    for (int ix = 0; ix < nx_; ++ix) {
      const int xs[2] = {ix, x_next_[ix]};
      const int ys[2] = {iy, y_next_[iy]};
      std::int64_t corner[8];
      for (int c = 0; c < 8; ++c) {
        const Corner& k = kCorners[c];
        corner[c] = node(xs[k.dx], ys[k.dy], iz + k.dz);
      }
      cell(static_cast<const std::int64_t(&)[8]>(corner));
    }
}

template <class Node>
void System::top_layer(Node&& node_tied) const {
  for (std::int64_t n = node(0, 0, nz_ - 1); n < n_; ++n) node_tied(n);
}

template <class Driven>
void System::driven(double t, const double* u, const double* w, Driven&& node_tied) const {
  const double anchor = v_ * t;
  top_layer([&](std::int64_t n) {
    const double *un = u + 3 * n, *wn = w + 3 * n;
    node_tied(n, DriveGap{{anchor - un[0], -un[1], -un[2]}, {v_ - wn[0], -wn[1], -wn[2]}});
  });
}

// Every member up to contact_set_ in the member initializers, in their
// order: the contacts' law takes the force scale and η_c derived here.
System::System(const Case& c, std::vector<Contact> contacts)
    : nx_(c.lattice.nx),
      ny_(c.lattice.ny),
      nz_(c.lattice.nz),
      n_(std::int64_t{nx_} * ny_ * nz_),
      a_(c.lattice.spacing),
      mass_(c.material.density * a_ * a_ * a_),
      // §2: G1 = c_t², G2 from the paper's Eq. (1) or the Navier equation.
      g1_(c.material.youngs_modulus /
          (2.0 * (1.0 + c.material.poisson_ratio) * c.material.density)),
      g2_(c.material.grad_div == GradDiv::paper ? (1.0 + 2.0 * c.material.poisson_ratio) * g1_
                                                : g1_ / (1.0 - 2.0 * c.material.poisson_ratio)),
      // k1/m = G1/a², k2/m = G2/a², k_d = k1.
      k1_over_m_(g1_ / (a_ * a_)),
      k2_over_m_(g2_ / (a_ * a_)),
      kd_over_m_(k1_over_m_),
      // η = η̂ ω0, η_c = η̂_c ω0 with ω0 = c_l / a.
      eta_(c.damping.bulk * (longitudinal_speed() / a_)),
      eta_c_(c.damping.contact * (longitudinal_speed() / a_)),
      v_(c.drive.velocity),
      contact_force_scale_(c.interface.epsilon * a_ * a_ * c.interface.shear_stress / mass_),
      normal_force_(0.0),
      mu_prefactor_(c.interface.shear_stress / c.interface.max_pressure),
      contact_set_(c.interface, std::move(contacts), nx_, ny_, n_, mass_, contact_force_scale_,
                   eta_c_) {
  // §7, §14: F_N = ε θ P0 Nx Ny a² with θ the covered fraction, sites/(Nx Ny).
  const auto& iface = c.interface;
  normal_force_ = iface.epsilon * static_cast<double>(contact_set_.sites().size()) *
                  iface.max_pressure * a_ * a_;

  x_next_.resize(nx_);
  y_next_.resize(ny_);
  for (int i = 0; i < nx_; ++i) x_next_[i] = (i + 1) % nx_;
  for (int i = 0; i < ny_; ++i) y_next_[i] = (i + 1) % ny_;
}

System::Component System::component(std::int64_t i) const {
  if (i >= 6 * n_) return {static_cast<int>(6 + (i - 6 * n_))};
  const bool velocity = i >= 3 * n_;
  const std::int64_t r = velocity ? i - 3 * n_ : i;
  const std::int64_t n = r / 3;
  return {static_cast<int>((velocity ? 3 : 0) + r % 3), static_cast<int>(n % nx_),
          static_cast<int>((n / nx_) % ny_), static_cast<int>(n / (std::int64_t{nx_} * ny_))};
}

std::string System::describe_component(std::int64_t i) const {
  static const char* const kQuadratureNames[] = {"the work integral", "the dissipation integral",
                                                 "the friction impulse"};
  const Component c = component(i);
  if (c.kind >= 6) return kQuadratureNames[c.kind - 6];
  return std::string(c.kind >= 3 ? "w^" : "u^") + "xyz"[c.kind % 3] + " of node (" +
         std::to_string(c.ix) + ", " + std::to_string(c.iy) + ", " + std::to_string(c.iz) + ")";
}

double System::coverage() const {
  return static_cast<double>(contact_set_.sites().size()) / (nx_ * ny_);
}

void System::initial_state(InitialState initial, std::span<double> y) const {
  std::fill(y.begin(), y.end(), 0.0);
  if (initial == InitialState::sliding)
    for (std::int64_t n = 0; n < n_; ++n) y[w_index(n, 0)] = v_;
}

// Elastic, damping and drive accelerations (MODEL.md §3–5). Faces and cells are visited once each
// and their forces scattered to both ends, which counts periodic images with their multiplicity on
// small lattices exactly as §3 defines.
void System::lattice_accelerations(double t, std::span<const double> u_in,
                                   std::span<const double> w_in, std::span<double> acc_out,
                                   int threads) const {
  const double* u = u_in.data();
  const double* w = w_in.data();
  double* acc = acc_out.data();
  std::fill(acc, acc + 3 * n_, 0.0);
  const double k1 = k1_over_m_, k2 = k2_over_m_, eta = eta_;

  auto face = [&](std::int64_t i, std::int64_t j) {
    for (int k = 0; k < 3; ++k) {
      const double d = k1 * (u[3 * j + k] - u[3 * i + k]) + eta * (w[3 * j + k] - w[3 * i + k]);
      acc[3 * i + k] += d;
      acc[3 * j + k] -= d;
    }
  };
  // Cells: U_c = (k2/2) D_c², D_c = ¼ Σ_corners s·u, so F_corner = −k2 D_c ¼ s.
  auto cell = [&](const std::int64_t(&corner)[8]) {
    const double f = -k2 * 0.0625 * corner_sum(u, corner);  // −k2 (¼ Σ s·u) ¼
    for (int c = 0; c < 8; ++c) {
      double* ac = acc + 3 * corner[c];
      ac[0] += f * kCorners[c].sx;
      ac[1] += f * kCorners[c].sy;
      ac[2] += f * kCorners[c].sz;
    }
  };
  // Layer iz's faces and the faces and cells between it and iz + 1 add to
  // layers iz and iz + 1 only, so the even layers can run at once, then the
  // odd ones (threads > 1). Every entry receives its terms in the same order
  // whatever the number of threads: results do not depend on it.
  auto layer = [&](int iz) {
    faces(iz, face);
    cells(iz, cell);
  };
  for (int parity = 0; parity < 2; ++parity)
    parallel_for(threads, (nz_ - parity + 1) / 2,
                 [&](std::int64_t k) { layer(parity + 2 * static_cast<int>(k)); });

  // Drive springs and dashpots to the plate moving at (v, 0, 0) (§5).
  driven(t, u, w, [&](std::int64_t n, const DriveGap& gap) {
    for (int k = 0; k < 3; ++k) acc[3 * n + k] += drive_acceleration(gap, k);
  });
}

void System::rhs_explicit(double t, std::span<const double> y, std::span<double> ydot,
                          int threads) const {
  std::copy(y.begin() + 3 * n_, y.begin() + 6 * n_, ydot.begin());  // u' = w
  lattice_accelerations(t, y.subspan(0, 3 * n_), y.subspan(3 * n_, 3 * n_),
                        ydot.subspan(3 * n_, 3 * n_), threads);
  const auto rates = quadrature_rates(t, y);
  std::copy(rates.begin(), rates.end(), ydot.begin() + quadrature_index(work_in));
}

std::array<double, System::kQuadratures> System::quadrature_rates(double t,
                                                                  std::span<const double> y) const {
  return {power_in(t, y), dissipation(y), friction_force(t, y)};
}

void System::rhs_implicit(double, std::span<const double> y, std::span<double> ydot) const {
  std::fill(ydot.begin(), ydot.end(), 0.0);
  contact_set_.add_accelerations(y, ydot);
}

void System::rhs(double t, std::span<const double> y, std::span<double> ydot, int threads) const {
  rhs_explicit(t, y, ydot, threads);
  contact_set_.add_accelerations(y, ydot);
}

SparseJacobian System::jacobian_pattern(JacobianPart part) const {
  using Triplet = Eigen::Triplet<double, std::int64_t>;
  std::vector<Triplet> t;
  const std::int64_t size = this->size();
  // site_rows keeps the sites' w rows only: the triplets of the whole
  // matrix are ~27 KiB a node, far more than a run's own state.
  std::vector<char> kept_row;
  if (part == JacobianPart::site_rows) {
    kept_row.assign(static_cast<std::size_t>(size), 0);
    for (const auto& site : contact_set_.sites())
      for (int r = 0; r < 2; ++r) kept_row[static_cast<std::size_t>(w_index(site.node, r))] = 1;
  }
  auto add = [&](std::int64_t r, std::int64_t c, double v) {
    if (kept_row.empty() || kept_row[static_cast<std::size_t>(r)]) t.emplace_back(r, c, v);
  };
  for (std::int64_t r = 0; r < size; ++r) add(r, r, 0.0);
  for (const auto& site : contact_set_.sites()) {
    const std::int64_t wx = w_index(site.node, 0);
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) add(wx + r, wx + c, 0.0);
  }
  if (part != JacobianPart::contacts) {
    // u' = w.
    for (std::int64_t r = 0; r < 3 * n_; ++r) add(r, 3 * n_ + r, 1.0);
    // Faces: a_i += k1 (u_j − u_i) + η (w_j − w_i), and the opposite on j.
    auto face = [&](std::int64_t i, std::int64_t j) {
      for (int k = 0; k < 3; ++k)
        for (auto [coef, offset] : {std::pair{k1_over_m_, std::int64_t{0}}, {eta_, 3 * n_}}) {
          add(w_index(i, k), offset + 3 * j + k, coef);
          add(w_index(i, k), offset + 3 * i + k, -coef);
          add(w_index(j, k), offset + 3 * i + k, coef);
          add(w_index(j, k), offset + 3 * j + k, -coef);
        }
    };
    for (int iz = 0; iz < nz_; ++iz) faces(iz, face);
    // Cells: ∂a_c/∂u_d = −(k2/16) s_c s_dᵀ.
    for (int iz = 0; iz < nz_; ++iz)
      cells(iz, [&](const std::int64_t(&corner)[8]) {
        for (int ci = 0; ci < 8; ++ci)
          for (int di = 0; di < 8; ++di) {
            const Corner &c = kCorners[ci], &d = kCorners[di];
            const double sc[3] = {c.sx, c.sy, c.sz}, sd[3] = {d.sx, d.sy, d.sz};
            for (int k = 0; k < 3; ++k)
              for (int l = 0; l < 3; ++l)
                add(w_index(corner[ci], k), u_index(corner[di], l),
                    -k2_over_m_ * 0.0625 * sc[k] * sd[l]);
          }
      });
    // Drive: drive_acceleration's ∂/∂u = −k_d, ∂/∂w = −η (the gap is the
    // plate's less the node's).
    top_layer([&](std::int64_t n) {
      for (int k = 0; k < 3; ++k) {
        add(w_index(n, k), u_index(n, k), -kd_over_m_);
        add(w_index(n, k), w_index(n, k), -eta_);
      }
    });
  }
  Eigen::SparseMatrix<double, Eigen::RowMajor, std::int64_t> m(size, size);
  m.setFromTriplets(t.begin(), t.end());
  m.makeCompressed();

  SparseJacobian jac;
  jac.size = size;
  jac.row_start.assign(m.outerIndexPtr(), m.outerIndexPtr() + size + 1);
  jac.column.assign(m.innerIndexPtr(), m.innerIndexPtr() + m.nonZeros());
  jac.constant_value.assign(m.valuePtr(), m.valuePtr() + m.nonZeros());
  jac.value = jac.constant_value;
  auto slot = [&](std::int64_t r, std::int64_t c) {
    const auto first = jac.column.begin() + jac.row_start[r];
    const auto last = jac.column.begin() + jac.row_start[r + 1];
    return static_cast<std::int64_t>(std::lower_bound(first, last, c) - jac.column.begin());
  };
  for (const auto& site : contact_set_.sites()) {
    const std::int64_t wx = w_index(site.node, 0);
    jac.contact_slot.push_back(
        {slot(wx, wx), slot(wx, wx + 1), slot(wx + 1, wx), slot(wx + 1, wx + 1)});
  }
  return jac;
}

void System::jacobian_values(std::span<const double> y, SparseJacobian& jac) const {
  std::copy(jac.constant_value.begin(), jac.constant_value.end(), jac.value.begin());
  contact_set_.add_jacobian_blocks(y, jac.contact_slot, jac.value);
}

double System::drive_stretch(double t, std::span<const double> y) const {
  double sum = 0.0;
  driven(t, y.data(), y.data() + 3 * n_,
         [&](std::int64_t, const DriveGap& gap) { sum += gap.du[0]; });
  return sum;
}

double System::friction_force(double t, std::span<const double> y) const {
  return mass_ * kd_over_m_ * drive_stretch(t, y);
}

double System::power_in(double t, std::span<const double> y) const {
  double sum = 0.0;
  driven(t, y.data(), y.data() + 3 * n_,
         [&](std::int64_t, const DriveGap& gap) { sum += drive_acceleration(gap, 0); });
  return mass_ * v_ * sum;
}

double System::lattice_dissipation(std::span<const double> y) const {
  const double* w = y.data() + 3 * n_;
  double face_sum = 0.0;
  auto face = [&](std::int64_t i, std::int64_t j) {
    for (int k = 0; k < 3; ++k) {
      const double d = w[3 * j + k] - w[3 * i + k];
      face_sum += d * d;
    }
  };
  for (int iz = 0; iz < nz_; ++iz) faces(iz, face);
  double drive = 0.0;  // (the dashpots' gap does not depend on t)
  driven(0.0, y.data(), w, [&](std::int64_t, const DriveGap& gap) {
    drive += gap.dw[0] * gap.dw[0] + gap.dw[1] * gap.dw[1] + gap.dw[2] * gap.dw[2];
  });
  return mass_ * eta_ * (face_sum + drive);
}

double System::dissipation(std::span<const double> y) const {
  return lattice_dissipation(y) + contact_set_.dissipation(y);
}

EnergyTerms System::energy(double t, std::span<const double> y) const {
  const double* u = y.data();
  const double* w = y.data() + 3 * n_;
  EnergyTerms e;
  for (std::int64_t r = 0; r < 3 * n_; ++r) e.kinetic += w[r] * w[r];
  e.kinetic *= 0.5 * mass_;

  double face_sum = 0.0, cell_sum = 0.0;
  auto face = [&](std::int64_t i, std::int64_t j) {
    for (int k = 0; k < 3; ++k) {
      const double d = u[3 * j + k] - u[3 * i + k];
      face_sum += d * d;
    }
  };
  for (int iz = 0; iz < nz_; ++iz) faces(iz, face);
  for (int iz = 0; iz < nz_; ++iz)
    cells(iz, [&](const std::int64_t(&corner)[8]) {
      const double d = 0.25 * corner_sum(u, corner);
      cell_sum += d * d;
    });
  e.elastic = 0.5 * mass_ * (k1_over_m_ * face_sum + k2_over_m_ * cell_sum);

  double spring = 0.0;
  driven(t, u, w, [&](std::int64_t, const DriveGap& gap) {
    spring += gap.du[0] * gap.du[0] + gap.du[1] * gap.du[1] + gap.du[2] * gap.du[2];
  });
  e.drive = 0.5 * mass_ * kd_over_m_ * spring;
  return e;
}

double System::energy_residual(double t, std::span<const double> y,
                               std::span<const double> y0) const {
  const double work = y[quadrature_index(work_in)];
  const double net = work - y[quadrature_index(dissipated)];
  const double change = energy(t, y).total() - energy(0.0, y0).total();
  return work != 0.0 ? (change - net) / work : 0.0;
}

double System::block_velocity(std::span<const double> y) const {
  double sum = 0.0;
  for (std::int64_t n = 0; n < n_; ++n) sum += y[w_index(n, 0)];
  return sum / static_cast<double>(n_);
}

double System::contact_impulse(double t, std::span<const double> y) const {
  double momentum = 0.0;
  for (std::int64_t n = 0; n < n_; ++n) momentum += y[w_index(n, 0)];
  return mass_ * (momentum - eta_ * drive_stretch(t, y)) - y[quadrature_index(friction_impulse)];
}

double System::steady_sliding_mu() const {
  const double mean_phi = contact_set_.mean_steady_phi(v_);
  // m η_c v / (ε P0 a²) = η_c v / (ε f0/m) × τ_f/P0.
  return mu_prefactor_ * (mean_phi + eta_c_ * v_ / contact_force_scale_);
}

}  // namespace stickslip
