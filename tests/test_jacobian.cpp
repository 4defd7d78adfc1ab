// The sparse Jacobians against central finite differences of the rhs.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <optional>
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
    for (std::size_t k = 0; k < system->contact_set().sites().size(); ++k) {
      y[system->w_index(system->contact_set().sites()[k].node, 0)] = speeds[k][0];
      y[system->w_index(system->contact_set().sites()[k].node, 1)] = speeds[k][1];
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
// The step: f is affine in every component but the contact sites' in-plane
// velocities (the contact force depends on nothing else, MODEL.md §6), and
// there a central difference is exact for any step, so the step is large
// (1e-6 m, 1e-3 m/s) and the quotient's rounding far below every entry. With
// the small steps the contact sites need (1e-7 of their speed), the rounding
// of a row's elastic terms (~2e6 m/s²) came to ~40 s⁻¹ and hid a 0.1 % error
// in a single damping entry (1e5 s⁻¹).
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
  std::vector<bool> nonlinear(rows, false);
  for (const FrictionSite& site : s.contact_set().sites())
    for (int k = 0; k < 2; ++k) nonlinear[static_cast<std::size_t>(s.w_index(site.node, k))] = true;
  for (std::size_t j = 0; j < rows; ++j) {
    const double h = nonlinear[j]            ? 1e-7 * std::max(std::abs(y[j]), 1e-4)
                     : j < 3 * s.num_nodes() ? 1e-6
                                             : 1e-3;
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

// The same Jacobian with the one entry (row, column) scaled by 1 + 1e-3;
// nothing if the pattern lacks it.
std::optional<SparseJacobian> one_entry_perturbed(const SparseJacobian& jac, std::int64_t row,
                                                  std::int64_t column) {
  SparseJacobian out = jac;
  for (auto k = jac.row_start[row]; k < jac.row_start[row + 1]; ++k)
    if (jac.column[k] == column) {
      out.value[k] *= 1 + 1e-3;
      return out;
    }
  return std::nullopt;
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
  for (std::size_t c = 0; c < s.contact_set().sites().size(); ++c)
    for (int k = 0; k < 2; ++k) contact_row[s.w_index(s.contact_set().sites()[c].node, k)] = true;
  const auto identity = perturbed(jac, [&](auto r, auto col) { return r < n3 && col >= n3; });
  const auto damping = perturbed(jac, [&](auto r, auto col) {
    return r >= n3 && r < 2 * n3 && col >= n3 && !contact_row[static_cast<std::size_t>(r)];
  });
  const auto elastic = perturbed(jac, [&](auto r, auto col) { return r >= n3 && col < n3; });
  CHECK(worst_entry_error(s, f.y, identity, rhs) > 10.0);
  CHECK(worst_entry_error(s, f.y, damping, rhs) > 10.0);
  CHECK(worst_entry_error(s, f.y, elastic, rhs) > 10.0);
}

TEST_CASE("a single entry 0.1 % wrong fails the check at every kind and scale of entry",
          "[jacobian]") {
  Fixture f;
  const System& s = *f.system;
  auto jac = s.jacobian_pattern(JacobianPart::full);
  s.jacobian_values(f.y, jac);
  auto rhs = [&](const auto& y, auto& out) { s.rhs(0.0, y, out); };
  REQUIRE(worst_entry_error(s, f.y, jac, rhs) <= 1.0);  // measured: 0.05
  // Nodes in the middle layer (iz = 1 of 3) and the top one (the drive's
  // dashpot on the diagonal); contacts 0 and 1 sit at (0, 0) and (2, 1) of
  // the bottom layer.
  const std::int64_t mid = s.node(1, 1, 1), next = s.node(2, 1, 1), top = s.node(1, 1, 2);
  const std::int64_t c0 = s.contact_set().sites()[0].node, c1 = s.contact_set().sites()[1].node;
  struct Entry {
    const char* what;
    std::int64_t row, column;
  };
  // Measured with every other entry exact (worst error in units of the
  // tolerance): 99.9 for the identity, the damping and the elastic entries,
  // 98 and 49 for the contact blocks; the true Jacobian is at 0.05. With the
  // small steps everywhere, a damping entry off the diagonal came out at
  // 0.91 (unseen), the diagonal ones at 3.2 and 7.3.
  for (const Entry& e : {
           Entry{"u-dot = w: du_x/dt by w_x", s.u_index(mid, 0), s.w_index(mid, 0)},
           Entry{"damping, diagonal (-6e5 1/s)", s.w_index(mid, 0), s.w_index(mid, 0)},
           Entry{"damping, neighbour along x (1e5 1/s)", s.w_index(mid, 1), s.w_index(next, 1)},
           Entry{"damping with the drive's dashpot, top node", s.w_index(top, 2),
                 s.w_index(top, 2)},
           Entry{"damping at a contact, z (no contact term)", s.w_index(c0, 2), s.w_index(c0, 2)},
           Entry{"elastic, diagonal", s.w_index(mid, 0), s.u_index(mid, 0)},
           Entry{"elastic, grad-div coupling x to y", s.w_index(mid, 0),
                 s.u_index(s.node(2, 2, 1), 1)},
           Entry{"contact block, xx with the damping", s.w_index(c0, 0), s.w_index(c0, 0)},
           Entry{"contact block, xy", s.w_index(c1, 0), s.w_index(c1, 1)},
       }) {
    const auto wrong = one_entry_perturbed(jac, e.row, e.column);
    INFO(e.what << ": " << s.describe_component(e.row) << " by " << s.describe_component(e.column));
    REQUIRE(wrong.has_value());
    CHECK(worst_entry_error(s, f.y, *wrong, rhs) > 10.0);
  }
}

TEST_CASE("contact Jacobian matches finite differences of the implicit rhs", "[jacobian]") {
  Fixture f;
  const System& s = *f.system;
  auto jac = s.jacobian_pattern(JacobianPart::contacts);
  // Identity-free: the diagonal is present but zero, plus a 2×2 block per contact.
  CHECK(jac.nonzeros() ==
        s.size() + 2 * static_cast<std::int64_t>(s.contact_set().contacts().size()));
  s.jacobian_values(f.y, jac);
  CHECK(worst_entry_error(s, f.y, jac,
                          [&](const auto& y, auto& out) { s.rhs_implicit(0.0, y, out); }) <= 1.0);
}

TEST_CASE("with 2x2 patches, every site's block matches finite differences", "[jacobian]") {
  Fixture f(2);
  const System& s = *f.system;
  REQUIRE(s.contact_set().sites().size() == 8);
  auto contacts = s.jacobian_pattern(JacobianPart::contacts);
  CHECK(contacts.nonzeros() ==
        s.size() + 2 * static_cast<std::int64_t>(s.contact_set().sites().size()));
  s.jacobian_values(f.y, contacts);
  CHECK(worst_entry_error(s, f.y, contacts,
                          [&](const auto& y, auto& out) { s.rhs_implicit(0.0, y, out); }) <= 1.0);
  auto full = s.jacobian_pattern(JacobianPart::full);
  s.jacobian_values(f.y, full);
  CHECK(worst_entry_error(s, f.y, full, [&](const auto& y, auto& out) { s.rhs(0.0, y, out); }) <=
        1.0);
}

TEST_CASE(
    "site_rows holds the full Jacobian's rows of the sites' in-plane accelerations and no other",
    "[jacobian]") {
  Fixture f;
  const System& s = *f.system;
  const auto full = s.jacobian_pattern(JacobianPart::full);
  const auto rows = s.jacobian_pattern(JacobianPart::site_rows);
  REQUIRE(rows.size == full.size);
  std::vector<char> site_row(static_cast<std::size_t>(s.size()), 0);
  for (const auto& site : s.contact_set().sites())
    for (int k = 0; k < 2; ++k) site_row[static_cast<std::size_t>(s.w_index(site.node, k))] = 1;
  for (std::int64_t r = 0; r < full.size; ++r) {
    const auto n = rows.row_start[r + 1] - rows.row_start[r];
    if (!site_row[static_cast<std::size_t>(r)]) {
      REQUIRE(n == 0);
      continue;
    }
    REQUIRE(n == full.row_start[r + 1] - full.row_start[r]);
    for (std::int64_t k = 0; k < n; ++k) {
      REQUIRE(rows.column[rows.row_start[r] + k] == full.column[full.row_start[r] + k]);
      REQUIRE(rows.constant_value[rows.row_start[r] + k] ==
              full.constant_value[full.row_start[r] + k]);
    }
  }
  CHECK(rows.nonzeros() < full.nonzeros() / 20);
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

TEST_CASE("the weakening rate is -d|a|/d|s| past v*, analytically, and 0 below it",
          "[jacobian][weakening]") {
  Case c;
  c.lattice = {4, 4, 3, 1e-4};
  c.interface.contacts = {{1, 1, 1e-3, 0}};
  const System s(c, {{1, 1, 1e-3}});
  std::vector<double> y(static_cast<std::size_t>(s.size()), 0.0);
  const std::int64_t wx = s.w_index(s.node(1, 1, 0), 0);
  CHECK(s.contact_set().weakening_rate(y) == 0.0);  // at rest
  y[wx] = 0.5e-3;                                   // rising branch
  CHECK(s.contact_set().weakening_rate(y) == 0.0);
  y[wx] = 10e-3;  // r = 10: φ = e^−c, φ' = −2c e^−c / (10 ln 10)
  const double a = c.lattice.spacing, m = c.material.density * a * a * a;
  const double force = c.interface.epsilon * c.interface.shear_stress * a * a / m;  // S
  const double g1 =
      c.material.youngs_modulus / (2 * (1 + c.material.poisson_ratio) * c.material.density);
  const double eta_c =
      c.damping.contact * std::sqrt(g1 + (1 + 2 * c.material.poisson_ratio) * g1) / a;
  const double shape = c.interface.shape;
  const double dphi = -2 * shape * std::exp(-shape) / (10 * std::log(10.0));
  CHECK(s.contact_set().weakening_rate(y) == Approx(-(force * dphi / 1e-3 + eta_c)).epsilon(1e-12));
  // The same as the radial entry of the contact's Jacobian block, ∂a_x/∂s_x
  // along ŝ = x̂: positive, a growth rate, where the force falls with speed.
  CHECK(s.contact_set().weakening_rate(y) ==
        Approx(s.contact_set().site_block(0, y)[0]).epsilon(1e-12));
}
