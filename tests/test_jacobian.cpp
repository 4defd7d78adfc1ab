// The sparse Jacobians against central finite differences of the rhs.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "stickslip/model/system.hpp"

using namespace stickslip;

namespace {

// A small lattice with contacts moving at 0.05–20 v*: away from rest, where
// finite differences of φ(|s|/v*)/|s| resolve (MODEL.md §6).
struct Fixture {
  Case c;
  std::vector<double> y;
  std::unique_ptr<System> system;
  Fixture() {
    c.lattice = {4, 3, 3, 1e-4};
    c.drive.velocity = 1e-3;
    std::vector<Contact> contacts = {{0, 0, 1e-3}, {2, 1, 4e-4}, {3, 2, 3e-3}};
    system = std::make_unique<System>(c, contacts);
    y.assign(static_cast<std::size_t>(system->size()), 0.0);
    std::mt19937_64 gen(3);
    std::uniform_real_distribution<double> d(-1.0, 1.0);
    for (std::int64_t i = 0; i < 3 * system->num_nodes(); ++i) y[i] = 1e-6 * d(gen);
    for (std::int64_t i = 3 * system->num_nodes(); i < 6 * system->num_nodes(); ++i)
      y[i] = 1e-3 * d(gen);
    const double speeds[3][2] = {{5e-5, 2e-5}, {-8e-3, 1e-3}, {2e-2, -3e-2}};
    for (std::size_t k = 0; k < 3; ++k) {
      y[system->w_index(system->contact_node(k), 0)] = speeds[k][0];
      y[system->w_index(system->contact_node(k), 1)] = speeds[k][1];
    }
  }
};

template <class Rhs>
void compare_with_finite_differences(const System& s, const std::vector<double>& y,
                                     const SparseJacobian& jac, Rhs rhs) {
  const auto size = static_cast<std::size_t>(s.size());
  // Dense copy of the sparse matrix.
  std::vector<double> dense(size * size, 0.0);
  for (std::size_t r = 0; r < size; ++r)
    for (auto k = jac.row_start[r]; k < jac.row_start[r + 1]; ++k)
      dense[r * size + jac.column[k]] = jac.value[k];
  std::vector<double> yp = y, ym = y, fp(size), fm(size);
  double worst = 0.0, scale = 0.0;
  for (double v : jac.value) scale = std::max(scale, std::abs(v));
  // Quadrature rows are left out of the Jacobian on purpose (nothing depends on them).
  const std::size_t rows = 6 * s.num_nodes();
  for (std::size_t j = 0; j < rows; ++j) {
    const double h = 1e-7 * std::max(std::abs(y[j]), j < 3 * s.num_nodes() ? 1e-6 : 1e-4);
    yp[j] = y[j] + h;
    ym[j] = y[j] - h;
    rhs(yp, fp);
    rhs(ym, fm);
    yp[j] = ym[j] = y[j];
    for (std::size_t i = 0; i < rows; ++i) {
      const double fd = (fp[i] - fm[i]) / (2 * h);
      const double err = std::abs(fd - dense[i * size + j]);
      worst = std::max(worst, err / (1e-6 * scale + 1e-5 * std::abs(fd)));
    }
  }
  CHECK(worst <= 1.0);
}

}  // namespace

TEST_CASE("full Jacobian matches finite differences", "[jacobian]") {
  Fixture f;
  const System& s = *f.system;
  auto jac = s.jacobian_pattern(JacobianPart::full);
  s.jacobian_values(f.y, jac);
  compare_with_finite_differences(s, f.y, jac,
                                  [&](const auto& y, auto& out) { s.rhs(0.0, y, out); });
}

TEST_CASE("contact Jacobian matches finite differences of the implicit rhs", "[jacobian]") {
  Fixture f;
  const System& s = *f.system;
  auto jac = s.jacobian_pattern(JacobianPart::contacts);
  // Identity-free: the diagonal is present but zero, plus a 2×2 block per contact.
  CHECK(jac.nonzeros() == s.size() + 2 * static_cast<std::int64_t>(s.contacts().size()));
  s.jacobian_values(f.y, jac);
  compare_with_finite_differences(s, f.y, jac,
                                  [&](const auto& y, auto& out) { s.rhs_implicit(0.0, y, out); });
}

TEST_CASE("every diagonal entry is in the pattern", "[jacobian]") {
  Fixture f;
  for (auto part : {JacobianPart::contacts, JacobianPart::full}) {
    const auto jac = f.system->jacobian_pattern(part);
    for (std::int64_t r = 0; r < jac.size; ++r) {
      bool found = false;
      for (auto k = jac.row_start[r]; k < jac.row_start[r + 1]; ++k) found |= jac.column[k] == r;
      REQUIRE(found);
    }
  }
}
