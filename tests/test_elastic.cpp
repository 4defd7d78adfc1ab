// Verification of the elastic operator of MODEL.md §3 against exact results.
#include <Eigen/Dense>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "stickslip/case/placement.hpp"
#include "stickslip/model/parallel_for.hpp"
#include "stickslip/model/system.hpp"

using namespace stickslip;

namespace {

Case lattice_case(int nx, int ny, int nz) {
  Case c;
  c.lattice = {nx, ny, nz, 1e-4};
  c.drive.velocity = 0.0;
  return c;
}

// Elastic accelerations K u / m alone: rhs at w = 0, t = 0, v = 0, no contacts,
// with the drive springs' known −(k_d/m) u on the top layer taken back out.
std::vector<double> elastic_acceleration(const System& s, const std::vector<double>& u) {
  std::vector<double> y(static_cast<std::size_t>(s.size()), 0.0), ydot(y.size());
  std::copy(u.begin(), u.end(), y.begin());
  s.rhs(0.0, y, ydot);
  std::vector<double> acc(ydot.begin() + 3 * s.num_nodes(), ydot.begin() + 6 * s.num_nodes());
  const double kd = s.g1() / (s.spacing() * s.spacing());
  for (int iy = 0; iy < s.ny(); ++iy)
    for (int ix = 0; ix < s.nx(); ++ix)
      for (int k = 0; k < 3; ++k) {
        const auto r = s.u_index(s.node(ix, iy, s.nz() - 1), k);
        acc[r] += kd * u[r];
      }
  return acc;
}

Eigen::MatrixXd stiffness_over_mass(const System& s) {
  const auto dof = 3 * s.num_nodes();
  Eigen::MatrixXd K(dof, dof);
  for (std::int64_t j = 0; j < dof; ++j) {
    std::vector<double> u(dof, 0.0);
    u[j] = 1.0;
    const auto a = elastic_acceleration(s, u);
    for (std::int64_t i = 0; i < dof; ++i) K(i, j) = a[i];
  }
  return K;
}

}  // namespace

TEST_CASE("elastic operator is symmetric, translation-free and negative semi-definite",
          "[elastic]") {
  for (auto [nx, ny, nz] : {std::tuple{4, 3, 3}, {2, 3, 2}, {1, 4, 3}}) {
    const System s(lattice_case(nx, ny, nz), {});
    const Eigen::MatrixXd K = stiffness_over_mass(s);
    const double scale = K.cwiseAbs().maxCoeff();
    INFO("lattice " << nx << "x" << ny << "x" << nz);
    CHECK((K - K.transpose()).cwiseAbs().maxCoeff() <= 1e-12 * scale);

    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd t = Eigen::VectorXd::Zero(K.rows());
      for (std::int64_t n = 0; n < s.num_nodes(); ++n) t(3 * n + k) = 1.0;
      CHECK((K * t).cwiseAbs().maxCoeff() <= 1e-12 * scale);
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(-K);
    const auto& lambda = eig.eigenvalues();  // ascending
    CHECK(lambda(0) >= -1e-10 * scale);
    // With Nx, Ny ≥ 2 the three rigid translations are the only zero modes.
    if (nx >= 2) {
      CHECK(std::abs(lambda(2)) <= 1e-10 * scale);
      CHECK(lambda(3) > 1e-4 * scale);
    }
  }
}

TEST_CASE("elastic energy is the quadratic form of the forces", "[elastic]") {
  const System s(lattice_case(5, 4, 3), {});
  std::mt19937_64 gen(7);
  std::uniform_real_distribution<double> d(-1e-6, 1e-6);
  std::vector<double> u(3 * s.num_nodes());
  for (auto& x : u) x = d(gen);
  const auto a = elastic_acceleration(s, u);
  double work = 0.0;
  for (std::size_t i = 0; i < u.size(); ++i) work += u[i] * a[i];
  std::vector<double> y(static_cast<std::size_t>(s.size()), 0.0);
  std::copy(u.begin(), u.end(), y.begin());
  // U = −½ uᵀ K u = −½ m Σ u·a; the drive spring energy is separate.
  CHECK(s.energy(0.0, y).elastic == Approx(-0.5 * s.mass() * work).epsilon(1e-12));
  CHECK(s.energy(0.0, y).elastic > 0.0);
}

TEST_CASE("transverse plane waves along x are exact eigenmodes", "[elastic]") {
  const int nx = 12, ny = 3, nz = 4;
  const System s(lattice_case(nx, ny, nz), {});
  const double a = s.spacing();
  for (int p : {1, 3, 6})
    for (int comp : {1, 2}) {
      const double q = 2 * std::numbers::pi * p / (nx * a);
      std::vector<double> u(3 * s.num_nodes(), 0.0);
      for (std::int64_t n = 0; n < s.num_nodes(); ++n)
        u[3 * n + comp] = std::sin(q * a * (n % nx) + 0.3);
      const auto acc = elastic_acceleration(s, u);
      const double omega = 2 / a * std::sqrt(s.g1()) * std::sin(q * a / 2);
      double worst = 0.0;
      for (std::size_t i = 0; i < u.size(); ++i)
        worst = std::max(worst, std::abs(acc[i] + omega * omega * u[i]));
      INFO("p = " << p << ", component " << comp);
      CHECK(worst <= 1e-10 * omega * omega);
    }
}

TEST_CASE("longitudinal plane waves along x are eigenmodes on the interior layers", "[elastic]") {
  const int nx = 12, ny = 3, nz = 5;
  const System s(lattice_case(nx, ny, nz), {});
  const double a = s.spacing();
  for (int p : {1, 2, 5}) {
    const double q = 2 * std::numbers::pi * p / (nx * a);
    std::vector<double> u(3 * s.num_nodes(), 0.0);
    for (std::int64_t n = 0; n < s.num_nodes(); ++n) u[3 * n] = std::cos(q * a * (n % nx));
    const auto acc = elastic_acceleration(s, u);
    const double omega = 2 / a * std::sqrt(s.g1() + s.g2()) * std::sin(q * a / 2);
    double worst = 0.0, surface_misfit = 0.0;
    for (std::int64_t n = 0; n < s.num_nodes(); ++n) {
      const double r = std::abs(acc[3 * n] + omega * omega * u[3 * n]);
      const auto iz = n / (nx * ny);
      if (iz == 0 || iz == nz - 1)
        surface_misfit = std::max(surface_misfit, r);
      else
        worst = std::max({worst, r, std::abs(acc[3 * n + 1]), std::abs(acc[3 * n + 2])});
    }
    INFO("p = " << p);
    CHECK(worst <= 1e-10 * omega * omega);
    // The free surfaces see half the cells, so the mode is not exact there.
    CHECK(surface_misfit > 1e-3 * omega * omega);
  }
}

TEST_CASE("long-wave speeds tend to sqrt(G1) and sqrt(G1+G2)", "[elastic]") {
  // Rayleigh quotients of the longest waves on ever longer lattices: the phase
  // speed ω/q approaches the continuum sound speed with error ∝ (qa)².
  double previous_t = 1.0, previous_l = 1.0;
  for (int nx : {8, 16, 32}) {
    const System s(lattice_case(nx, 1, 3), {});
    const double a = s.spacing(), q = 2 * std::numbers::pi / (nx * a);
    auto speed = [&](int comp, bool interior_only) {
      std::vector<double> u(3 * s.num_nodes(), 0.0);
      for (std::int64_t n = 0; n < s.num_nodes(); ++n) u[3 * n + comp] = std::sin(q * a * (n % nx));
      const auto acc = elastic_acceleration(s, u);
      double num = 0.0, den = 0.0;
      for (std::int64_t n = 0; n < s.num_nodes(); ++n) {
        if (interior_only && n / nx != 1) continue;
        num -= u[3 * n + comp] * acc[3 * n + comp];
        den += u[3 * n + comp] * u[3 * n + comp];
      }
      return std::sqrt(num / den) / q;
    };
    const double err_t = std::abs(speed(1, false) / std::sqrt(s.g1()) - 1);
    const double err_l = std::abs(speed(0, true) / std::sqrt(s.g1() + s.g2()) - 1);
    const double expected = std::pow(q * a, 2) / 24;  // 1 − sin(x/2)/(x/2) ≈ x²/24
    CHECK(err_t == Approx(expected).epsilon(0.02));
    CHECK(err_l == Approx(expected).epsilon(0.02));
    CHECK(err_t < previous_t / 3.9);
    CHECK(err_l < previous_l / 3.9);
    previous_t = err_t;
    previous_l = err_l;
  }
}

TEST_CASE("the lattice forces do not depend on the number of threads", "[elastic][threads]") {
  // Odd and even layer counts: the parallel loop runs even layers, then odd.
  for (int nz : {5, 6}) {
    Case c = lattice_case(7, 5, nz);
    c.drive.velocity = 1e-3;
    c.interface.coverage = 0.3;
    std::mt19937_64 gen(5);
    std::uniform_real_distribution<double> r(-1.0, 1.0);
    const System serial(c, place_contacts(c.lattice, c.interface));
    std::vector<double> y(static_cast<std::size_t>(serial.size()));
    for (std::size_t i = 0; i < y.size(); ++i) y[i] = (i < y.size() / 2 ? 1e-6 : 1e-3) * r(gen);
    std::vector<double> expected(y.size()), got(y.size());
    serial.rhs(1e-4, y, expected);
    for (int threads : {2, 3}) {
      serial.rhs(1e-4, y, got, threads);
      INFO("nz = " << nz << ", threads = " << threads);
      CHECK(got == expected);  // bit for bit: every entry sums its terms in one order
    }
  }
}

TEST_CASE("parallel_for visits every index once and rethrows the first index's exception",
          "[threads]") {
  for (int threads : {1, 2, 3}) {
    INFO("threads " << threads);
    std::vector<int> visits(1000, 0);
    stickslip::parallel_for(threads, 1000,
                            [&](std::int64_t i) { ++visits[static_cast<std::size_t>(i)]; });
    CHECK(std::count(visits.begin(), visits.end(), 1) == 1000);
    // Indices 700 and 300 throw: the loop finishes, and 300's error comes out.
    std::vector<int> done(1000, 0);
    try {
      stickslip::parallel_for(threads, 1000, [&](std::int64_t i) {
        if (i == 700 || i == 300) throw std::runtime_error("at " + std::to_string(i));
        done[static_cast<std::size_t>(i)] = 1;
      });
      FAIL("no exception");
    } catch (const std::runtime_error& e) {
      CHECK(std::string(e.what()) == "at 300");
    }
    CHECK(std::count(done.begin(), done.end(), 1) == (threads == 1 ? 300 : 998));
  }
}
