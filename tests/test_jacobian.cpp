// The sparse Jacobians against central finite differences of the rhs.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>

#include "stickslip/model/system.hpp"

using namespace stickslip;

namespace {

// A small lattice with contacts (single sites, or two 2×2 patches, MODEL.md
// §14) whose sites move at 0.05–75 v*: away from rest, where finite
// differences of φ(|s|/v*)/|s| resolve (MODEL.md §6).
struct Fixture {
  Case c;
  std::vector<double> y;
  std::unique_ptr<System> system;
  explicit Fixture(int patch = 1) {
    c.lattice = {4, 3, 3, 1e-4};
    c.drive.velocity = 1e-3;
    c.interface.patch = patch;
    std::vector<Contact> contacts = {{0, 0, 1e-3}, {2, 1, 4e-4}, {3, 2, 3e-3}};
    if (patch > 1) contacts.pop_back();  // the third would overlap
    system = std::make_unique<System>(c, contacts);
    y.assign(static_cast<std::size_t>(system->size()), 0.0);
    std::mt19937_64 gen(3);
    std::uniform_real_distribution<double> d(-1.0, 1.0);
    for (std::int64_t i = 0; i < 3 * system->num_nodes(); ++i) y[i] = 1e-6 * d(gen);
    for (std::int64_t i = 3 * system->num_nodes(); i < 6 * system->num_nodes(); ++i)
      y[i] = 1e-3 * d(gen);
    const double speeds[8][2] = {{5e-5, 2e-5},  {-8e-3, 1e-3}, {2e-2, -3e-2},  {3e-4, -1e-4},
                                 {-2e-4, 6e-5}, {1e-3, 4e-3},  {-9e-3, -2e-2}, {4e-5, 3e-5}};
    for (std::size_t k = 0; k < system->sites().size(); ++k) {
      y[system->w_index(system->sites()[k].node, 0)] = speeds[k][0];
      y[system->w_index(system->sites()[k].node, 1)] = speeds[k][1];
    }
  }
};

// The largest error of any entry against a central finite difference, each
// in units of that entry's own tolerance: 1e-5 of the entry (or of the
// difference quotient) plus the rounding of the quotient, 8 ε (|f_i| plus
// the size of the terms it sums) / h.
// Per entry, not against the largest entry (~3e11 s⁻², the elastic terms):
// that scale would hide an error in a damping term (~1e5 s⁻¹) or in the
// u̇ = w rows (1).
template <class Rhs>
double worst_entry_error(const System& s, const std::vector<double>& y, const SparseJacobian& jac,
                         Rhs rhs) {
  const auto size = static_cast<std::size_t>(s.size());
  // Dense copy of the sparse matrix.
  std::vector<double> dense(size * size, 0.0);
  for (std::size_t r = 0; r < size; ++r)
    for (auto k = jac.row_start[r]; k < jac.row_start[r + 1]; ++k)
      dense[r * size + jac.column[k]] = jac.value[k];
  std::vector<double> yp = y, ym = y, fp(size), fm(size);
  double worst = 0.0;
  // Quadrature rows are left out of the Jacobian on purpose (nothing depends on them).
  const std::size_t rows = 6 * s.num_nodes();
  constexpr double eps = std::numeric_limits<double>::epsilon();
  // The rhs sums terms far larger than itself (elastic forces of nearly equal
  // neighbours): its rounding is relative to Σ_j |J_ij y_j|, not to |f_i|.
  std::vector<double> terms(rows, 0.0);
  for (std::size_t r = 0; r < rows; ++r)
    for (auto k = jac.row_start[r]; k < jac.row_start[r + 1]; ++k)
      terms[r] += std::abs(jac.value[k] * y[static_cast<std::size_t>(jac.column[k])]);
  for (std::size_t j = 0; j < rows; ++j) {
    const double h = 1e-7 * std::max(std::abs(y[j]), j < 3 * s.num_nodes() ? 1e-6 : 1e-4);
    yp[j] = y[j] + h;
    ym[j] = y[j] - h;
    rhs(yp, fp);
    rhs(ym, fm);
    yp[j] = ym[j] = y[j];
    for (std::size_t i = 0; i < rows; ++i) {
      const double fd = (fp[i] - fm[i]) / (2 * h), entry = dense[i * size + j];
      const double rounding = 8 * eps * (terms[i] + std::max(std::abs(fp[i]), std::abs(fm[i]))) / h;
      const double tolerance = 1e-5 * std::max(std::abs(entry), std::abs(fd)) + rounding;
      worst = std::max(worst, std::abs(fd - entry) / tolerance);
    }
  }
  return worst;
}

// The same Jacobian with the entries that `pick(row, column)` selects scaled
// by 1 + 1e-3: what worst_entry_error must catch.
template <class Pick>
SparseJacobian perturbed(const SparseJacobian& jac, Pick pick) {
  SparseJacobian out = jac;
  for (std::int64_t r = 0; r < jac.size; ++r)
    for (auto k = jac.row_start[r]; k < jac.row_start[r + 1]; ++k)
      if (pick(r, jac.column[k])) out.value[k] *= 1 + 1e-3;
  return out;
}

}  // namespace

TEST_CASE("full Jacobian matches finite differences", "[jacobian]") {
  Fixture f;
  const System& s = *f.system;
  auto jac = s.jacobian_pattern(JacobianPart::full);
  s.jacobian_values(f.y, jac);
  auto rhs = [&](const auto& y, auto& out) { s.rhs(0.0, y, out); };
  CHECK(worst_entry_error(s, f.y, jac, rhs) <= 1.0);

  // Every kind of entry is checked at its own scale: a 0.1 % error in the
  // u̇ = w identity, in the damping (∂a/∂w away from the contacts) or in the
  // elastic terms (∂a/∂u) is caught.
  const std::int64_t n3 = 3 * s.num_nodes();
  std::vector<bool> contact_row(static_cast<std::size_t>(s.size()), false);
  for (std::size_t c = 0; c < s.sites().size(); ++c)
    for (int k = 0; k < 2; ++k) contact_row[s.w_index(s.sites()[c].node, k)] = true;
  const auto identity = perturbed(jac, [&](auto r, auto col) { return r < n3 && col >= n3; });
  const auto damping = perturbed(jac, [&](auto r, auto col) {
    return r >= n3 && r < 2 * n3 && col >= n3 && !contact_row[static_cast<std::size_t>(r)];
  });
  const auto elastic = perturbed(jac, [&](auto r, auto col) { return r >= n3 && col < n3; });
  CHECK(worst_entry_error(s, f.y, identity, rhs) > 10.0);
  CHECK(worst_entry_error(s, f.y, damping, rhs) > 10.0);
  CHECK(worst_entry_error(s, f.y, elastic, rhs) > 10.0);
}

TEST_CASE("contact Jacobian matches finite differences of the implicit rhs", "[jacobian]") {
  Fixture f;
  const System& s = *f.system;
  auto jac = s.jacobian_pattern(JacobianPart::contacts);
  // Identity-free: the diagonal is present but zero, plus a 2×2 block per contact.
  CHECK(jac.nonzeros() == s.size() + 2 * static_cast<std::int64_t>(s.contacts().size()));
  s.jacobian_values(f.y, jac);
  CHECK(worst_entry_error(s, f.y, jac,
                          [&](const auto& y, auto& out) { s.rhs_implicit(0.0, y, out); }) <= 1.0);
}

TEST_CASE("with 2x2 patches, every site's block matches finite differences", "[jacobian]") {
  Fixture f(2);
  const System& s = *f.system;
  REQUIRE(s.sites().size() == 8);
  auto contacts = s.jacobian_pattern(JacobianPart::contacts);
  CHECK(contacts.nonzeros() == s.size() + 2 * static_cast<std::int64_t>(s.sites().size()));
  s.jacobian_values(f.y, contacts);
  CHECK(worst_entry_error(s, f.y, contacts,
                          [&](const auto& y, auto& out) { s.rhs_implicit(0.0, y, out); }) <= 1.0);
  auto full = s.jacobian_pattern(JacobianPart::full);
  s.jacobian_values(f.y, full);
  CHECK(worst_entry_error(s, f.y, full, [&](const auto& y, auto& out) { s.rhs(0.0, y, out); }) <=
        1.0);
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
