// The exact stage solves of dirk and bdf (LatticeSolver, LatticeStageSolver)
// against direct sparse LU solves of I − γJ, with J assembled by the
// System's Jacobian (its own stencil code, checked against finite differences
// in test_jacobian.cpp; the solvers read the operator from the rhs instead).
#include <Eigen/SparseLU>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>

#include "stickslip/integrate/contact_substeps.hpp"
#include "stickslip/integrate/lattice_solver.hpp"
#include "stickslip/integrate/lattice_stage_solver.hpp"
#include "stickslip/model/system.hpp"

using namespace stickslip;

namespace {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, std::int64_t>;

// I − γ J over the 6N state rows (no quadratures), J = ∂f/∂y at y.
SparseMatrix stage_matrix(const System& s, double gamma, const std::vector<double>& y) {
  SparseJacobian jac = s.jacobian_pattern(JacobianPart::full);
  s.jacobian_values(y, jac);
  const std::int64_t n = 6 * s.num_nodes();
  std::vector<Eigen::Triplet<double, std::int64_t>> t;
  for (std::int64_t r = 0; r < n; ++r) {
    t.emplace_back(r, r, 1.0);
    for (auto k = jac.row_start[r]; k < jac.row_start[r + 1]; ++k)
      if (jac.column[k] < n) t.emplace_back(r, jac.column[k], -gamma * jac.value[k]);
  }
  SparseMatrix m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  m.makeCompressed();
  return m;
}

// M = I − γ J_ww − γ² J_wu: the Schur complement of (I − γJ) once u = b_u + γ w
// is eliminated (J_uw = I), symmetric positive definite and well conditioned
// where I − γJ itself is not (~1e7 at γ = 1e-4): the direct reference solve.
SparseMatrix velocity_matrix(const System& s, double gamma) {
  const std::vector<double> y(static_cast<std::size_t>(s.size()), 0.0);
  SparseJacobian jac = s.jacobian_pattern(JacobianPart::full);
  s.jacobian_values(y, jac);
  const std::int64_t n3 = 3 * s.num_nodes();
  std::vector<Eigen::Triplet<double, std::int64_t>> t;
  for (std::int64_t r = 0; r < n3; ++r) t.emplace_back(r, r, 1.0);
  for (std::int64_t r = n3; r < 2 * n3; ++r)
    for (auto k = jac.row_start[r]; k < jac.row_start[r + 1]; ++k) {
      const std::int64_t col = jac.column[k];
      if (col < n3)
        t.emplace_back(r - n3, col, -gamma * gamma * jac.value[k]);
      else if (col < 2 * n3)
        t.emplace_back(r - n3, col - n3, -gamma * jac.value[k]);
    }
  SparseMatrix m(n3, n3);
  m.setFromTriplets(t.begin(), t.end());
  m.makeCompressed();
  return m;
}

Eigen::VectorXd direct_solve(const SparseMatrix& m, const Eigen::VectorXd& rhs) {
  Eigen::SparseLU<SparseMatrix> lu;
  lu.compute(m);
  REQUIRE(lu.info() == Eigen::Success);
  return lu.solve(rhs);
}

System make_system(int nx, int ny, int nz, std::vector<Contact> contacts, int patch = 1) {
  Case c;
  c.lattice = {nx, ny, nz, 1e-4};
  c.interface.patch = patch;
  return System(c, std::move(contacts));
}

// Largest |a − b| relative to the largest |b|, over displacements and over
// velocities separately (their scales differ by ~1e4).
double relative_difference(const System& s, std::span<const double> a, std::span<const double> b) {
  const std::int64_t n3 = 3 * s.num_nodes();
  double worst = 0.0;
  for (std::int64_t block : {0L, n3}) {
    double diff = 0.0, scale = 0.0;
    for (std::int64_t i = block; i < block + n3; ++i) {
      diff = std::max(diff, std::abs(a[i] - b[i]));
      scale = std::max(scale, std::abs(b[i]));
    }
    worst = std::max(worst, diff / scale);
  }
  return worst;
}

// A state of realistic size: displacements ~1 µm, velocities ~1 mm/s.
std::vector<double> random_state(const System& s, unsigned seed) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  std::vector<double> y(static_cast<std::size_t>(s.size()));
  for (std::int64_t i = 0; i < 3 * s.num_nodes(); ++i) y[i] = 1e-6 * d(gen);
  for (std::int64_t i = 3 * s.num_nodes(); i < 6 * s.num_nodes(); ++i) y[i] = 1e-3 * d(gen);
  for (int q = 0; q < System::kQuadratures; ++q) y[6 * s.num_nodes() + q] = 1e-9 * d(gen);
  return y;
}

// How far one Newton step on z − γ f(t, z) = b, with the exact Jacobian at z
// solved by sparse LU, moves z (relative_difference): zero at an exact stage.
double direct_newton_change(const System& s, double t, double gamma, const std::vector<double>& b,
                            const std::vector<double>& z) {
  const std::int64_t n = 6 * s.num_nodes();
  std::vector<double> f(b.size());
  s.rhs(t, z, f);
  Eigen::VectorXd residual(n);
  for (std::int64_t i = 0; i < n; ++i) residual[i] = b[i] - (z[i] - gamma * f[i]);
  const Eigen::VectorXd step = direct_solve(stage_matrix(s, gamma, z), residual);
  std::vector<double> newton(z.begin(), z.begin() + n);
  for (std::int64_t i = 0; i < n; ++i) newton[i] += step[i];
  return relative_difference(s, newton, std::span<const double>(z.data(), n));
}

// 40 contacts on 12×10×3 (a third of the bottom layer), some pairs adjacent.
std::vector<Contact> forty_contacts() {
  std::vector<Contact> contacts;
  std::mt19937 rng(3);
  std::vector<bool> taken(120, false);
  while (contacts.size() < 40) {
    const int site = static_cast<int>(rng() % 120);
    if (taken[static_cast<std::size_t>(site)]) continue;
    taken[static_cast<std::size_t>(site)] = true;
    contacts.push_back(
        {site % 12, site / 12, 4e-4 + 1e-4 * static_cast<double>(contacts.size() % 7)});
  }
  return contacts;
}

struct Shape {
  int nx, ny, nz;
};
// Nx, Ny = 1 (no x-faces), 2 (two faces between the same two nodes), odd and
// even; Nz = 1 (top and bottom layer at once) to 4.
constexpr Shape kShapes[] = {{1, 1, 2}, {2, 3, 3}, {3, 2, 1}, {4, 4, 3}, {5, 4, 2}, {1, 4, 4}};
constexpr double kGammas[] = {1e-9, 1e-7, 3e-6, 1e-4};

}  // namespace

TEST_CASE("the lattice solve of a stage agrees with a direct sparse solve of I - gamma J",
          "[lattice_solver]") {
  for (const Shape& shape : kShapes) {
    const System s = make_system(shape.nx, shape.ny, shape.nz, {});
    LatticeStageSolver solver(s);
    const double t = 2e-4;  // the plate has moved: its forcing is in the stage
    for (double gamma : kGammas) {
      const std::vector<double> b = random_state(s, 7);
      std::vector<double> z = b;
      const std::vector<double> weights(b.size(), 1.0);
      solver.solve(t, gamma, b, weights, z);

      // f is affine without contacts: (I − γJ) z = b + γ f(t, 0) =: c, solved
      // directly through its Schur complement: M z_w = c_w + γ J_wu c_u,
      // z_u = c_u + γ z_w.
      std::vector<double> zero(b.size(), 0.0), f0(b.size());
      s.rhs(t, zero, f0);
      const std::int64_t n = 6 * s.num_nodes(), n3 = n / 2;
      std::vector<double> c(b.size());
      for (std::int64_t i = 0; i < n; ++i) c[i] = b[i] + gamma * f0[i];
      std::vector<double> ju(b.size(), 0.0), jcu(b.size());
      std::copy(c.begin(), c.begin() + n3, ju.begin());  // (c_u, 0)
      s.rhs(0.0, ju, jcu);
      s.rhs(0.0, zero, f0);  // J (c_u, 0) = f(0, (c_u, 0)) − f(0, 0)
      Eigen::VectorXd rhs(n3);
      for (std::int64_t i = 0; i < n3; ++i) rhs[i] = c[n3 + i] + gamma * (jcu[n3 + i] - f0[n3 + i]);
      const Eigen::VectorXd w = direct_solve(velocity_matrix(s, gamma), rhs);
      Eigen::VectorXd direct(n);
      for (std::int64_t i = 0; i < n3; ++i) {
        direct[n3 + i] = w[i];
        direct[i] = c[i] + gamma * w[i];
      }
      INFO(shape.nx << "x" << shape.ny << "x" << shape.nz << ", gamma " << gamma);
      CHECK(relative_difference(s, z, std::span<const double>(direct.data(), n)) < 1e-10);

      // The quadratures: q = b_q + γ q'(t, z).
      std::vector<double> f(b.size());
      s.rhs(t, z, f);
      for (int q = 0; q < System::kQuadratures; ++q) {
        const std::size_t i = static_cast<std::size_t>(n + q);
        CHECK(z[i] == Approx(b[i] + gamma * f[i]).epsilon(1e-12));
      }
    }
  }
}

TEST_CASE(
    "the bottom layer's Green's function is M^-1 between bottom nodes, symmetric and "
    "translation-invariant",
    "[lattice_solver]") {
  for (const Shape& shape : kShapes) {
    const System s = make_system(shape.nx, shape.ny, shape.nz, {});
    LatticeSolver solver(s);
    for (double gamma : {1e-7, 1e-5}) {
      solver.set_gamma(gamma);
      // Columns of M⁻¹ from direct solves with unit velocity sources.
      const SparseMatrix m = velocity_matrix(s, gamma);
      const std::int64_t n3 = 3 * s.num_nodes();
      double worst = 0.0, scale = 0.0;
      // Two source sites: the same offsets must give the same entries.
      for (auto [sx, sy] : {std::pair{0, 0}, std::pair{shape.nx - 1, shape.ny / 2}})
        for (int b = 0; b < 2; ++b) {
          Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n3);
          rhs[s.w_index(s.node(sx, sy, 0), b) - n3] = 1.0;
          const Eigen::VectorXd col = direct_solve(m, rhs);
          for (int ix = 0; ix < shape.nx; ++ix)
            for (int iy = 0; iy < shape.ny; ++iy)
              for (int a = 0; a < 2; ++a) {
                const double direct = col[s.w_index(s.node(ix, iy, 0), a) - n3];
                const double green = solver.green(ix - sx, iy - sy, a, b);
                worst = std::max(worst, std::abs(green - direct));
                scale = std::max(scale, std::abs(direct));
                // Symmetry of M⁻¹: g_ab(Δ) = g_ba(−Δ).
                CHECK(solver.green(sx - ix, sy - iy, b, a) == Approx(green).margin(1e-13 * scale));
                // The lookup by a wrapped offset is the same entry.
                const int dx = (ix - sx + shape.nx) % shape.nx,
                          dy = (iy - sy + shape.ny) % shape.ny;
                CHECK(solver.green_wrapped(dx + std::int64_t{shape.nx} * dy, a, b) == green);
              }
        }
      INFO(shape.nx << "x" << shape.ny << "x" << shape.nz << ", gamma " << gamma);
      CHECK(worst < 1e-10 * scale);
    }
  }
}

TEST_CASE(
    "the lattice solve in parts (held solution, its bottom-layer velocity, a bottom-layer "
    "source added) is M^-1 (r + P^T f)",
    "[lattice_solver]") {
  for (const Shape& shape : kShapes) {
    const System s = make_system(shape.nx, shape.ny, shape.nz, {});
    LatticeSolver solver(s);
    for (double gamma : {1e-7, 3e-6}) {
      solver.set_gamma(gamma);
      const std::int64_t n3 = 3 * s.num_nodes();
      const std::vector<double> y = random_state(s, 11);
      const std::vector<double> r(y.begin() + n3, y.begin() + 2 * n3);
      const SparseMatrix m = velocity_matrix(s, gamma);
      const Eigen::Map<const Eigen::VectorXd> rv(r.data(), n3);
      const Eigen::VectorXd held = direct_solve(m, rv);

      solver.begin_solve(r);
      // The held solution's bottom layer, in-plane.
      solver.held_surface_velocity();
      const auto field = solver.surface_field();
      const std::size_t layer = field.size() / 2;
      double worst = 0.0, scale = 0.0;
      for (int ix = 0; ix < shape.nx; ++ix)
        for (int iy = 0; iy < shape.ny; ++iy)
          for (int a = 0; a < 2; ++a) {
            const double direct = held[s.w_index(s.node(ix, iy, 0), a) - n3];
            worst = std::max(
                worst,
                std::abs(field[a * layer + static_cast<std::size_t>(ix + shape.nx * iy)] - direct));
            scale = std::max(scale, std::abs(direct));
          }
      INFO(shape.nx << "x" << shape.ny << "x" << shape.nz << ", gamma " << gamma);
      CHECK(worst < 1e-12 * scale);

      // In-plane forces on the bottom layer, added to the held solution.
      std::mt19937 rng(5);
      std::uniform_real_distribution<double> uniform(-1.0, 1.0);
      Eigen::VectorXd source = rv;
      for (int ix = 0; ix < shape.nx; ++ix)
        for (int iy = 0; iy < shape.ny; ++iy)
          for (int a = 0; a < 2; ++a) {
            const double f = 1e-3 * uniform(rng);
            field[a * layer + static_cast<std::size_t>(ix + shape.nx * iy)] = f;
            source[s.w_index(s.node(ix, iy, 0), a) - n3] += f;
          }
      solver.add_surface_source();
      std::vector<double> w(r.size());
      solver.finish_solve(w);
      const Eigen::VectorXd direct = direct_solve(m, source);
      const Eigen::Map<const Eigen::VectorXd> wv(w.data(), n3);
      CHECK((wv - direct).cwiseAbs().maxCoeff() < 1e-12 * direct.cwiseAbs().maxCoeff());
    }
  }
}

TEST_CASE("convolving a bottom-layer field by FFT gives the sum over the Green's function",
          "[lattice_solver]") {
  for (const Shape& shape : kShapes) {
    const System s = make_system(shape.nx, shape.ny, shape.nz, {});
    LatticeSolver solver(s);
    solver.set_gamma(1e-6);
    const auto field = solver.surface_field();
    const std::size_t layer = static_cast<std::size_t>(shape.nx * shape.ny);
    REQUIRE(field.size() == 2 * layer);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    std::vector<double> source(field.size());
    for (double& v : source) v = uniform(rng);
    std::copy(source.begin(), source.end(), field.begin());
    solver.convolve_surface();
    double worst = 0.0, scale = 0.0;
    for (int ix = 0; ix < shape.nx; ++ix)
      for (int iy = 0; iy < shape.ny; ++iy)
        for (int a = 0; a < 2; ++a) {
          double sum = 0.0;
          for (int jx = 0; jx < shape.nx; ++jx)
            for (int jy = 0; jy < shape.ny; ++jy)
              for (int b = 0; b < 2; ++b)
                sum += solver.green(ix - jx, iy - jy, a, b) *
                       source[b * layer + static_cast<std::size_t>(jx + shape.nx * jy)];
          const double fft = field[a * layer + static_cast<std::size_t>(ix + shape.nx * iy)];
          worst = std::max(worst, std::abs(fft - sum));
          scale = std::max(scale, std::abs(sum));
        }
    INFO(shape.nx << "x" << shape.ny << "x" << shape.nz);
    CHECK(scale > 0.0);
    CHECK(worst < 1e-12 * scale);
  }
}

TEST_CASE("a stage with contacts is solved exactly: a direct Newton step from it changes nothing",
          "[lattice_solver]") {
  struct Layout {
    Shape shape;
    std::vector<Contact> contacts;
    const char* what;
    int patch = 1;
  };
  const std::vector<Layout> layouts = {
      {{4, 4, 3}, {{1, 2, 4.75e-4}}, "one contact"},
      {{5, 4, 2}, {{1, 1, 4.75e-4}, {2, 1, 2.09e-3}}, "adjacent contacts"},
      {{4, 3, 3}, {{3, 0, 1e-3}, {0, 0, 5e-4}, {3, 2, 2e-3}}, "contacts across the periodic seam"},
      {{2, 3, 2}, {{0, 0, 1e-3}, {1, 0, 6e-4}, {1, 2, 3e-3}}, "Nx = 2"},
      {{1, 4, 3}, {{0, 1, 1e-3}, {0, 2, 7e-4}}, "Nx = 1, Nx != Ny"},
      {{6, 5, 3},
       {{0, 0, 1e-3},
        {1, 0, 6e-4},
        {3, 1, 3e-3},
        {5, 2, 4.75e-4},
        {2, 4, 2.09e-3},
        {4, 4, 8e-4},
        {0, 3, 1.5e-3}},
       "seven contacts, some neighbours, some across the seams"},
      {{6, 6, 3},
       {{5, 5, 1e-3}, {1, 1, 6e-4}, {3, 0, 3e-3}, {2, 3, 7e-4}},
       "2x2 patches, one wrapping around both seams",
       2},
  };
  for (const Layout& layout : layouts) {
    const System s = make_system(layout.shape.nx, layout.shape.ny, layout.shape.nz, layout.contacts,
                                 layout.patch);
    // The solve's exactness at any γ: no stage refused for its γ λ (that
    // refusal: test_methods.cpp, "a loose rtol does not step over a slip").
    LatticeStageSolver solver(s, std::numeric_limits<double>::infinity());
    for (double gamma : kGammas) {
      // Contacts from rest to fast slip; the predictor is b.
      std::vector<double> b = random_state(s, 11);
      const double speeds[3][2] = {{3e-9, 1e-9}, {-4e-3, 1e-3}, {5e-2, -2e-2}};
      for (std::size_t k = 0; k < s.contact_set().sites().size();
           ++k) {  // a patch: each of its sites
        b[s.w_index(s.contact_set().sites()[k].node, 0)] = speeds[k % 3][0];
        b[s.w_index(s.contact_set().sites()[k].node, 1)] = speeds[k % 3][1];
      }
      std::vector<double> z = b;
      std::vector<double> weights(b.size());
      // rtol 1e-6; atol 1e-12 m, 1e-9 m/s.
      for (std::size_t i = 0; i < b.size(); ++i)
        weights[i] = 1.0 / (1e-6 * std::abs(b[i]) +
                            (static_cast<std::int64_t>(i) < 3 * s.num_nodes() ? 1e-12 : 1e-9));
      const double t = 1e-4;
      solver.solve(t, gamma, b, weights, z);

      INFO(layout.what << ", gamma " << gamma);
      CHECK(direct_newton_change(s, t, gamma, b, z) < 1e-10);
      // The stage moved the first contact's speed (b held it at 3e-9 m/s):
      // the contacts' forces mattered, the test is not of a trivial stage.
      const std::int64_t w0 = s.w_index(s.contact_set().sites()[0].node, 0);
      CHECK(std::abs(z[w0] - b[w0]) > 1e3 * std::abs(b[w0]));
    }
  }
}

TEST_CASE(
    "a stage leaving a slipping contact with gamma lambda above the limit is refused, and only "
    "that",
    "[lattice_solver]") {
  // One contact past its peak force (slipping at 2 v*), the rest random; the
  // same stage solved without a limit tells what γ λ its answer has. The
  // limit is lowered from its 1 to 0.01 so that this small state has answers
  // on both sides of it (its slip decays at large γ: λ = 0 there).
  constexpr double kLimit = 0.01;
  const System s = make_system(4, 4, 3, {{1, 2, 4.75e-4}});
  LatticeStageSolver limited(s, kLimit), unlimited(s, std::numeric_limits<double>::infinity());
  int refused = 0, solved = 0;
  for (double gamma : {1e-10, 1e-9, 3e-9, 1e-8, 1e-7, 1e-6, 1e-5}) {
    std::vector<double> b = random_state(s, 3);
    b[s.w_index(s.contact_set().sites()[0].node, 0)] = 9.5e-4;
    const std::vector<double> weights(b.size(), 1e6);
    std::vector<double> free = b, z = b;
    unlimited.solve(1e-4, gamma, b, weights, free);
    const double gamma_lambda = gamma * s.contact_set().weakening_rate(free);
    INFO("gamma " << gamma << ", gamma lambda " << gamma_lambda);
    if (gamma_lambda > kLimit) {
      CHECK_THROWS_AS(limited.solve(1e-4, gamma, b, weights, z), StageNotConverged);
      ++refused;
    } else {
      limited.solve(1e-4, gamma, b, weights, z);
      CHECK(z == free);  // the limit changes nothing below it
      ++solved;
    }
  }
  CHECK(refused > 0);  // both sides of the limit were tried
  CHECK(solved > 0);
}

TEST_CASE("a stage with many contacts gives the same bits on 1, 2 and 3 threads",
          "[lattice_solver][threads]") {
  // 40 contacts on 12×10×3, from rest to fast slip: the Newton iteration on
  // their coupled speeds runs, with an LU, and each thread count splits the
  // contacts, the lattice's modes and the Newton matrix's columns its own way.
  const std::vector<Contact> contacts = forty_contacts();
  std::vector<std::vector<double>> results;
  std::vector<long> iterations;
  for (int threads : {1, 2, 3}) {
    const System s = make_system(12, 10, 3, contacts);
    const auto budget = std::make_shared<const ThreadBudget>(threads);
    REQUIRE(budget->now() == threads);
    LatticeStageSolver solver(s, std::numeric_limits<double>::infinity(),
                              LatticeStageSolver::ContactNewton::by_count, budget);
    std::vector<double> b = random_state(s, 5);
    const double speeds[3][2] = {{3e-9, 1e-9}, {-4e-3, 1e-3}, {5e-2, -2e-2}};
    for (std::size_t k = 0; k < s.contact_set().sites().size(); ++k) {
      b[s.w_index(s.contact_set().sites()[k].node, 0)] = speeds[k % 3][0];
      b[s.w_index(s.contact_set().sites()[k].node, 1)] = speeds[k % 3][1];
    }
    std::vector<double> weights(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) weights[i] = 1.0 / (1e-6 * std::abs(b[i]) + 1e-9);
    long its = 0;
    std::vector<double> z;
    for (double gamma : {1e-7, 3e-6}) {  // two γ: the lattice refactorized, the LU kept or rebuilt
      z = b;
      its += solver.solve(1e-4, gamma, b, weights, z);
      results.push_back(z);
    }
    iterations.push_back(its);
  }
  CHECK(iterations[0] > 2);  // Newton iterated: the coupled solve was exercised
  for (std::size_t k = 2; k < results.size(); ++k) {
    INFO("run " << k / 2 + 1 << " threads, gamma " << (k % 2 ? 3e-6 : 1e-7));
    CHECK(results[k] == results[k % 2]);  // bit for bit
  }
  CHECK(iterations[1] == iterations[0]);
  CHECK(iterations[2] == iterations[0]);
}

TEST_CASE(
    "on layers of 32x32 and more (an FFT plan per layer) the lattice solve is M^-1, the same bits "
    "on 1 and 3 threads",
    "[lattice_solver][threads]") {
  // 32×32 and 33×32 (odd: a layer's start is not 16-byte aligned) at Nz = 3:
  // the plans per layer that threads take, not the one plan of small layers.
  for (const Shape& shape : {Shape{32, 32, 3}, Shape{33, 32, 3}}) {
    std::vector<std::vector<double>> solutions;
    for (int threads : {1, 3}) {
      const System s = make_system(shape.nx, shape.ny, shape.nz, {});
      LatticeSolver solver(s, std::make_shared<const ThreadBudget>(threads));
      const double gamma = 3e-6;
      solver.set_gamma(gamma);
      const std::int64_t n3 = 3 * s.num_nodes();
      const std::vector<double> y = random_state(s, 9);
      const std::vector<double> r(y.begin() + n3, y.begin() + 2 * n3);
      std::vector<double> w(r.size());
      solver.solve(r, w);
      // M w = r, with M from the Jacobian (velocity_matrix).
      const Eigen::VectorXd mw =
          velocity_matrix(s, gamma) * Eigen::Map<const Eigen::VectorXd>(w.data(), n3);
      const Eigen::Map<const Eigen::VectorXd> rv(r.data(), n3);
      INFO(shape.nx << "x" << shape.ny << "x" << shape.nz << ", threads " << threads);
      CHECK((mw - rv).cwiseAbs().maxCoeff() < 1e-12 * rv.cwiseAbs().maxCoeff());
      solutions.push_back(w);
    }
    CHECK(solutions[1] == solutions[0]);
  }
}

TEST_CASE(
    "stages solved with a Newton matrix kept from earlier stages and step sizes are exact, and "
    "share one LU",
    "[lattice_solver]") {
  // A slip's sequence of stages: γ moving by tens of per cent, the contacts'
  // speeds (from rest to fast slip) changing from stage to stage. The
  // contacts' Newton steps are solved by Krylov iterations preconditioned
  // with the LU of the first stage; each stage must still be exact.
  const System s = make_system(12, 10, 3, forty_contacts());
  LatticeStageSolver solver(s, std::numeric_limits<double>::infinity());
  const std::vector<double> base = random_state(s, 5);
  const double speeds[3][2] = {{3e-9, 1e-9}, {-4e-3, 1e-3}, {5e-2, -2e-2}};
  const double gammas[] = {1e-7, 1.2e-7, 0.9e-7, 1.5e-7, 1.1e-7, 2e-7};
  long iterations = 0;
  for (std::size_t stage = 0; stage < std::size(gammas); ++stage) {
    std::vector<double> b = base;
    for (std::size_t k = 0; k < s.contact_set().sites().size();
         ++k) {  // each contact's speed moves
      const double scale = 1.0 + 0.05 * static_cast<double>((k + stage) % 5);
      b[s.w_index(s.contact_set().sites()[k].node, 0)] = scale * speeds[(k + stage / 2) % 3][0];
      b[s.w_index(s.contact_set().sites()[k].node, 1)] = scale * speeds[(k + stage / 2) % 3][1];
    }
    std::vector<double> weights(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) weights[i] = 1.0 / (1e-6 * std::abs(b[i]) + 1e-9);
    std::vector<double> z = b;
    const double t = 1e-4;
    iterations += solver.solve(t, gammas[stage], b, weights, z);
    INFO("stage " << stage << ", gamma " << gammas[stage]);
    CHECK(direct_newton_change(s, t, gammas[stage], b, z) < 1e-10);
  }
  CHECK(iterations > static_cast<long>(std::size(gammas)));  // Newton iterated
  CHECK(solver.krylov_iterations() > 0);  // the kept LU alone was too slow: Krylov steps
  // The first stage's LU preconditioned the rest: far fewer LUs than stages.
  CHECK(solver.contact_factorizations() <= 2);
}

TEST_CASE(
    "the contacts' matrix-free Newton steps (GMRES, near-field preconditioner) give the dense "
    "LU's stage to the solver's tolerance",
    "[lattice_solver]") {
  // 200 contacts on half of a 20×20×4 bottom layer, from rest to fast slip,
  // at step sizes from a slip's to a creep's (γ = 1e-4: H couples every
  // contact to every other). The two paths differ only in how Newton's steps
  // are solved; the residual, and so the stage, is the same to the
  // tolerance the Newton iteration stops at (1e-6 in the weights below).
  std::vector<Contact> contacts;
  std::mt19937 rng(7);
  std::vector<bool> taken(400, false);
  while (contacts.size() < 200) {
    const int site = static_cast<int>(rng() % 400);
    if (taken[static_cast<std::size_t>(site)]) continue;
    taken[static_cast<std::size_t>(site)] = true;
    contacts.push_back(
        {site % 20, site / 20, 4e-4 + 1e-4 * static_cast<double>(contacts.size() % 7)});
  }
  const System s = make_system(20, 20, 4, contacts);
  using Newton = LatticeStageSolver::ContactNewton;
  LatticeStageSolver dense(s, std::numeric_limits<double>::infinity(), Newton::dense_lu);
  LatticeStageSolver matrix_free(s, std::numeric_limits<double>::infinity(), Newton::matrix_free);
  REQUIRE(!dense.matrix_free());
  REQUIRE(matrix_free.matrix_free());
  const double speeds[3][2] = {{3e-9, 1e-9}, {-4e-5, 1e-5}, {5e-4, -2e-4}};
  // As the multirate stepper solves its coarse stages: every fifth site's
  // contact acceleration given (its fast contacts'), in both solvers alike.
  const bool prescribed = GENERATE(false, true);
  if (prescribed)
    for (std::size_t k = 0; k < s.contact_set().sites().size(); k += 5)
      for (auto* solver : {&dense, &matrix_free})
        solver->prescribe(k, {-3e2 * static_cast<double>(k % 3), 1e2});
  for (double gamma : {1e-7, 1e-6, 3e-6, 1e-5, 1e-4}) {
    // A creeping lattice: displacements ~1 nm, velocities ~1 µm/s.
    std::vector<double> b = random_state(s, 13);
    for (std::int64_t i = 0; i < 6 * s.num_nodes(); ++i) b[static_cast<std::size_t>(i)] *= 1e-3;
    for (std::size_t k = 0; k < s.contact_set().sites().size(); ++k) {
      b[s.w_index(s.contact_set().sites()[k].node, 0)] = speeds[k % 3][0];
      b[s.w_index(s.contact_set().sites()[k].node, 1)] = speeds[k % 3][1];
    }
    std::vector<double> weights(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) weights[i] = 1.0 / (1e-6 * std::abs(b[i]) + 1e-9);
    const double t = 1e-4;
    std::vector<double> z_dense = b, z_free = b;
    const long dense_iterations = dense.solve(t, gamma, b, weights, z_dense);
    matrix_free.solve(t, gamma, b, weights, z_free);
    INFO("gamma " << gamma << (prescribed ? ", a fifth of the sites prescribed" : ""));
    CHECK(dense_iterations > 1);  // the contacts are coupled: Newton iterated
    // Each contact's speed within 1e-5 of its error weight's scale: ten
    // times the Newton tolerance, for J⁻¹ between residual and speed.
    double worst = 0.0;
    for (std::size_t k = 0; k < s.contact_set().sites().size(); ++k)
      for (int a = 0; a < 2; ++a) {
        const auto i = static_cast<std::size_t>(s.w_index(s.contact_set().sites()[k].node, a));
        worst = std::max(worst, std::abs(z_free[i] - z_dense[i]) * weights[i]);
      }
    CHECK(worst < 1e-5);
    CHECK(relative_difference(s, z_free, z_dense) < 1e-9);
  }
  CHECK(matrix_free.krylov_iterations() > 0);
  CHECK(matrix_free.contact_factorizations() > 0);  // of the near field
}

TEST_CASE(
    "a prescribed law p + q s that cancels its node's own stiffness and damping leaves the node "
    "moved by the rest of the lattice and the given acceleration alone",
    "[lattice_solver]") {
  // The multirate stepper's stand-in for a fast contact: a_c = ℓ − K u − C w
  // at the stage, u = b_u + γ w, so p = ℓ − K b_u and q = −(C + γ K) ≥ 0.
  // Its node's stage is then w = b_w + γ (Φ(z) + ℓ), Φ the rest of the
  // lattice's acceleration on it (NodeCoupling::forcing) at the stage solved,
  // whatever its own K and C: the identity checked here at three sites among
  // forty coupled contacts, at step sizes from a slip's to a creep's.
  const System s = make_system(12, 10, 3, forty_contacts());
  const auto couplings = node_couplings(s);
  LatticeStageSolver solver(s, std::numeric_limits<double>::infinity());
  const std::size_t given[] = {0, 3, 7};
  const std::array<double, 2> line{2e2, -1e2};
  for (double gamma : {1e-9, 1e-8, 1e-7}) {
    std::vector<double> b = random_state(s, 11);
    for (std::int64_t i = 0; i < 6 * s.num_nodes(); ++i) b[static_cast<std::size_t>(i)] *= 1e-3;
    std::vector<double> weights(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) weights[i] = 1.0 / (1e-6 * std::abs(b[i]) + 1e-9);
    solver.release_all();
    for (const std::size_t j : given) {
      const NodeCoupling& c = couplings[j];
      const auto ux = static_cast<std::size_t>(s.u_index(s.contact_set().sites()[j].node, 0));
      solver.prescribe(j, {line[0] - c.stiffness * b[ux], line[1] - c.stiffness * b[ux + 1]},
                       -(c.damping + gamma * c.stiffness));
    }
    std::vector<double> z = b;
    solver.solve(1e-4, gamma, b, weights, z);
    INFO("gamma " << gamma);
    for (const std::size_t j : given) {
      const NodeCoupling& c = couplings[j];
      const auto ux = static_cast<std::size_t>(s.u_index(s.contact_set().sites()[j].node, 0));
      const auto wx = static_cast<std::size_t>(s.w_index(s.contact_set().sites()[j].node, 0));
      const auto phi = c.forcing(z.data());
      for (std::size_t k = 0; k < 2; ++k) {
        const double residual = z[wx + k] - b[wx + k] - gamma * (phi[k] + line[k]);
        // What the node's own K u + C w would have added: far above the
        // tolerance, so the identity is not met by a stage they barely move.
        const double own = gamma * (c.stiffness * z[ux + k] + c.damping * z[wx + k]);
        CHECK(std::abs(residual) * weights[wx + k] < 1e-3);
        CHECK(std::abs(own) * weights[wx + k] > 1e2);
        CHECK(z[ux + k] == Approx(b[ux + k] + gamma * z[wx + k]).epsilon(1e-12));
      }
    }
  }
}

TEST_CASE(
    "GMRES's Newton steps converge in Newton's own weights where stuck contacts weigh thousands "
    "of times the slipping ones",
    "[lattice_solver]") {
  // A block slip's stages on a creeping lattice: first every contact
  // slipping at ~0.1 m/s (the LU is built there), then two thirds of them
  // held at ~1 µm/s by their force beside the slipping rest, weighted as the
  // integrator weighs them at rtol 1e-5 with atol 3e-10 m/s (rtol × 0.1 ×
  // v*): a stuck contact's weight ~3e9 s/m, a slipping one's ~1e6. The LU
  // kept from the first stage is a poor Newton matrix for the stuck ones, so
  // the later stages take Krylov steps. Each stage must converge, and be
  // exact. (This state converges with GMRES unweighted too; the 15×15×10
  // multirate run that stalled on it is in docs/notes/performance-history.md.)
  const System s = make_system(12, 10, 3, forty_contacts());
  LatticeStageSolver solver(s, std::numeric_limits<double>::infinity());
  // A creeping lattice: displacements ~1 nm, velocities ~1 µm/s.
  std::vector<double> base = random_state(s, 5);
  for (std::int64_t i = 0; i < 6 * s.num_nodes(); ++i) base[static_cast<std::size_t>(i)] *= 1e-3;
  const double stuck[2] = {1e-6, -2e-8}, slipping[2] = {1e-1, -2e-2};
  const double gammas[] = {1e-6, 3e-9, 5e-9, 8e-9, 1.2e-8, 2e-8, 1e-8, 4e-9};
  for (std::size_t stage = 0; stage < std::size(gammas); ++stage) {
    std::vector<double> b = base, start = base;
    for (std::size_t k = 0; k < s.contact_set().sites().size(); ++k) {
      const double scale = 1.0 + 0.05 * static_cast<double>((k + stage) % 5);
      const double* speed = stage == 0 || k % 3 == 2 ? slipping : stuck;
      const std::array<double, 2> v{scale * speed[0], scale * speed[1]};
      // b such that the contact alone would end its stage at v: held by its
      // force, a stuck contact's b is far larger than its speed.
      const auto a = s.contact_set().site_acceleration(k, v);
      b[s.w_index(s.contact_set().sites()[k].node, 0)] = v[0] - gammas[stage] * a[0];
      b[s.w_index(s.contact_set().sites()[k].node, 1)] = v[1] - gammas[stage] * a[1];
      start[s.w_index(s.contact_set().sites()[k].node, 0)] = v[0];
      start[s.w_index(s.contact_set().sites()[k].node, 1)] = v[1];
    }
    std::vector<double> weights(b.size());
    for (std::size_t i = 0; i < b.size(); ++i)
      weights[i] = 1.0 / (1e-5 * std::abs(start[i]) +
                          (static_cast<std::int64_t>(i) < 3 * s.num_nodes() ? 1e-13 : 3e-10));
    std::vector<double> z = b;
    const double t = 1e-4;
    INFO("stage " << stage << ", gamma " << gammas[stage]);
    REQUIRE_NOTHROW(solver.solve(t, gammas[stage], b, weights, z));
    CHECK(direct_newton_change(s, t, gammas[stage], b, z) < 1e-10);
  }
  CHECK(solver.krylov_iterations() > 0);  // the Krylov steps were exercised
}
