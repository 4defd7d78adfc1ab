#include "stickslip/integrate/contact_substeps.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "stickslip/integrate/dirk_tables.hpp"

namespace stickslip {

EsdirkTable esdirk_table(int order) {
  ARKodeButcherTable t = ARKodeButcherTable_LoadDIRK(dirk_table(order));
  if (t == nullptr || t->d == nullptr)
    throw std::logic_error("esdirk_table: SUNDIALS has no table");
  EsdirkTable out;
  out.stages = t->stages;
  out.order = t->q;
  out.embedded_order = t->p;
  for (int i = 0; i < t->stages; ++i) {
    for (int j = 0; j < t->stages; ++j) out.a.push_back(t->A[i][j]);
    out.b.push_back(t->b[i]);
    out.d.push_back(t->d[i]);
    out.c.push_back(t->c[i]);
  }
  ARKodeButcherTable_Free(t);
  // What the steppers rely on: an explicit first stage, and y_{n+1} the last
  // stage (so its derivative is f at the step's end).
  const int s = out.stages;
  bool ok = out.at(0, 0) == 0.0 && out.c[0] == 0.0;
  for (int j = 0; j < s; ++j) ok = ok && std::abs(out.at(s - 1, j) - out.b[j]) < 1e-15;
  if (!ok) throw std::logic_error("esdirk_table: not a stiffly accurate ESDIRK");
  return out;
}

std::array<double, 2> NodeCoupling::forcing(const double* y) const {
  std::array<double, 2> out{};
  for (int k = 0; k < 2; ++k) {
    double sum = 0.0;
    for (std::size_t e = 0; e < column[k].size(); ++e) sum += value[k][e] * y[column[k][e]];
    out[k] = sum;
  }
  return out;
}

std::vector<NodeCoupling> node_couplings(const System& system) {
  const SparseJacobian jac = system.jacobian_pattern(JacobianPart::site_rows);
  if (system.nz() < 2)
    throw std::invalid_argument("a one-layer lattice: its contact nodes are driven");
  std::vector<NodeCoupling> out;
  out.reserve(system.contact_set().sites().size());
  for (const FrictionSite& site : system.contact_set().sites()) {
    NodeCoupling c;
    std::array<std::array<double, 2>, 2> k{}, d{};  // own blocks ∂a/∂u, ∂a/∂w (rows x, y)
    for (int r = 0; r < 2; ++r) {
      const std::int64_t row = system.w_index(site.node, r);
      for (std::int64_t e = jac.row_start[row]; e < jac.row_start[row + 1]; ++e) {
        const std::int64_t col = jac.column[e];
        const double v = jac.constant_value[e];
        bool own = false;
        for (int q = 0; q < 2; ++q) {
          if (col == system.u_index(site.node, q)) k[r][q] += v, own = true;
          if (col == system.w_index(site.node, q)) d[r][q] += v, own = true;
        }
        if (!own && v != 0.0) {
          c.column[r].push_back(col);
          c.value[r].push_back(v);
          const bool velocity = col >= 3 * system.num_nodes() && col < 6 * system.num_nodes();
          double& largest = velocity ? c.neighbour_damping : c.neighbour_stiffness;
          largest = std::max(largest, std::abs(v));
        }
      }
    }
    auto isotropic = [](const std::array<std::array<double, 2>, 2>& m) {
      const double scale = std::abs(m[0][0]) + std::abs(m[1][1]);
      return std::abs(m[0][1]) <= 1e-12 * scale && std::abs(m[1][0]) <= 1e-12 * scale &&
             std::abs(m[0][0] - m[1][1]) <= 1e-12 * scale;
    };
    if (!isotropic(k) || !isotropic(d))
      throw std::invalid_argument(
          "a contact node whose own in-plane stiffness or damping differs between x and y "
          "(a lattice 1 node wide)");
    c.stiffness = k[0][0];
    c.damping = d[0][0];
    out.push_back(std::move(c));
  }
  return out;
}

std::array<double, 2> Forcing::at(double tau) const {
  const double x = tau / H;
  std::array<double, 2> out{};
  for (int k = 0; k < 2; ++k) {
    double sum = 0.0;
    for (int p = kTerms - 1; p >= 0; --p) sum = sum * x + coefficient[k][p];
    out[k] = sum;
  }
  const SubstepResult* last = nullptr;
  std::array<double, 4> x_other{};
  for (const FineTerm& f : fine_terms) {  // grouped by source: one interpolation each
    if (f.source != last) {
      last = f.source;
      x_other = f.source->at(tau);
    }
    out[static_cast<std::size_t>(f.row)] +=
        f.coefficient * x_other[static_cast<std::size_t>(f.component)];
  }
  return out;
}

Forcing Forcing::taylor(double H, std::array<double, 2> value, std::array<double, 2> rate) {
  Forcing f;
  f.H = H;
  for (int k = 0; k < 2; ++k) {
    f.coefficient[k][0] = value[k];
    f.coefficient[k][1] = rate[k] * H;
  }
  return f;
}

Forcing Forcing::through(double H, std::span<const double> tau,
                         std::span<const std::array<double, 2>> values) {
  const auto n = static_cast<Eigen::Index>(tau.size());
  if (n > kTerms) throw std::logic_error("Forcing::through: too many points");
  // Vandermonde in x = τ/H ∈ [0, ~1]: well conditioned for the ≤ 7 stages.
  Eigen::MatrixXd v(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index p = 0; p < n; ++p) v(i, p) = std::pow(tau[i] / H, static_cast<double>(p));
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(v);
  Forcing f;
  f.H = H;
  for (int k = 0; k < 2; ++k) {
    Eigen::VectorXd rhs(n);
    for (Eigen::Index i = 0; i < n; ++i) rhs(i) = values[static_cast<std::size_t>(i)][k];
    const Eigen::VectorXd c = lu.solve(rhs);
    for (Eigen::Index p = 0; p < n; ++p) f.coefficient[k][p] = c(p);
  }
  return f;
}

namespace {

// The cubic Hermite between two points, at τ.
std::array<double, 4> hermite_at(const SubstepPoint& p, const SubstepPoint& q, double tau) {
  const double h = q.tau - p.tau;
  if (!(h > 0.0)) return q.x;
  const auto w = hermite_weights(std::clamp((tau - p.tau) / h, 0.0, 1.0), h);
  std::array<double, 4> out{};
  for (int k = 0; k < 4; ++k) out[k] = w.a * p.x[k] + w.b * p.f[k] + w.c * q.x[k] + w.d * q.f[k];
  return out;
}

// The sub-step holding τ (the last one if τ is past the end).
std::size_t interval_of(const std::vector<SubstepPoint>& points, double tau) {
  const auto it = std::upper_bound(points.begin(), points.end(), tau,
                                   [](double t, const SubstepPoint& p) { return t < p.tau; });
  const auto i = static_cast<std::size_t>(it - points.begin());
  return std::clamp<std::size_t>(i, 1, points.size() - 1);
}

}  // namespace

std::array<double, 4> SubstepResult::at(double tau) const {
  if (points.size() < 2) return points.back().x;
  const std::size_t i = interval_of(points, tau);
  return hermite_at(points[i - 1], points[i], tau);
}

double SubstepResult::dissipated_at(double tau) const {
  if (points.size() < 2) return points.back().dissipated;
  const std::size_t i = interval_of(points, tau);
  const SubstepPoint &p = points[i - 1], &q = points[i];
  const double s = std::clamp((tau - p.tau) / (q.tau - p.tau), 0.0, 1.0);
  return p.dissipated + s * (q.dissipated - p.dissipated);
}

ContactSubsteps::ContactSubsteps(const System& system, const EsdirkTable& table, double rtol,
                                 std::array<double, 4> atol)
    : system_(system), table_(table), rtol_(rtol), atol_(atol) {}

// One sub-step's stages over [τ, τ + h] from z[0], f[0] (the step's start):
// each stage's state z, derivative f and the contact's a_c as the stage
// equation has it. False where a stage is refused for γλ > 1.
bool ContactSubsteps::stages(std::size_t j, const NodeCoupling& coupling, const Forcing& forcing,
                             double tau, double h, std::vector<std::array<double, 4>>& z,
                             std::vector<std::array<double, 4>>& f,
                             std::vector<std::array<double, 2>>& ac) const {
  const int s = table_.stages;
  const double K = coupling.stiffness, C = coupling.damping;
  for (int i = 1; i < s; ++i) {
    std::array<double, 4> b = z[0];
    for (int l = 0; l < i; ++l)
      for (int k = 0; k < 4; ++k) b[k] += h * table_.at(i, l) * f[l][k];
    const double gamma = h * table_.at(i, i);
    const double ti = tau + table_.c[i] * h;
    const auto phi = forcing.at(ti);
    // u = b_u + γ w and w − γ (Φ + K u + C w + a_c(w)) = b_w:
    //     α w − γ a_c(w) = r,  α = 1 − γ C − γ² K,  r = b_w + γ (Φ + K b_u).
    const double alpha = 1.0 - gamma * C - gamma * gamma * K;
    const std::array<double, 2> r{b[2] + gamma * (phi[0] + K * b[0]),
                                  b[3] + gamma * (phi[1] + K * b[1])};
    const double predictor = std::hypot(z[i - 1][2], z[i - 1][3]);
    const ContactStage st = system_.contact_set().site_stage(
        j, gamma / alpha, {r[0] / alpha, r[1] / alpha}, predictor, false);
    z[i] = {b[0] + gamma * st.s[0], b[1] + gamma * st.s[1], st.s[0], st.s[1]};
    for (int k = 0; k < 4; ++k) f[i][k] = (z[i][k] - b[k]) / gamma;
    // a_c as the stage equation has it (not the law at z: near rest that
    // is noise, MODEL.md §6's 1e15 s⁻¹).
    ac[i] = {f[i][2] - phi[0] - K * z[i][0] - C * z[i][2],
             f[i][3] - phi[1] - K * z[i][1] - C * z[i][3]};
    // As the coarse stages (lattice_stage_solver.cpp): past γλ = 1 the
    // stage damps a slip's growth where the error estimate cannot see it.
    if (gamma * system_.contact_set().site_weakening_rate(j, st.s) > 1.0) return false;
  }
  return true;
}

// The weighted RMS of the embedded error estimate of a sub-step of size h
// from x with stage derivatives f.
double ContactSubsteps::error_norm(double h, const std::array<double, 4>& x,
                                   const std::vector<std::array<double, 4>>& f) const {
  const int s = table_.stages;
  double sum = 0.0;
  for (int k = 0; k < 4; ++k) {
    double e = 0.0;
    for (int l = 0; l < s; ++l) e += (table_.b[l] - table_.d[l]) * f[l][k];
    e *= h;
    const double weight = 1.0 / (rtol_ * std::abs(x[k]) + atol_[k]);
    sum += (e * weight) * (e * weight);
  }
  return std::sqrt(sum / 4.0);
}

SubstepResult ContactSubsteps::advance(std::size_t j, const NodeCoupling& coupling, double H,
                                       std::array<double, 4> x0, std::array<double, 2> a0,
                                       const Forcing& forcing, double h_try) const {
  const int s = table_.stages;
  const double K = coupling.stiffness, C = coupling.damping, m = system_.mass();
  // The controller's exponent: the embedding's order + 1.
  const double exponent = -1.0 / (table_.embedded_order + 1);
  SubstepResult out;
  auto derivative = [&](double tau, const std::array<double, 4>& x, std::array<double, 2> a) {
    const auto phi = forcing.at(tau);
    return std::array<double, 4>{x[2], x[3], phi[0] + K * x[0] + C * x[2] + a[0],
                                 phi[1] + K * x[1] + C * x[3] + a[1]};
  };
  std::array<double, 4> x = x0;
  std::array<double, 2> a = a0;
  out.points.push_back({0.0, x, derivative(0.0, x, a), 0.0});

  std::vector<std::array<double, 4>> z(s), f(s);
  std::vector<std::array<double, 2>> ac(s);
  double tau = 0.0;
  double h = std::min(h_try, H);
  while (tau < H) {
    if (out.substeps + out.rejected > kMaxSubsteps || !(h > 1e-18))
      throw StageNotConverged("contact site " + std::to_string(j) +
                              "'s sub-steps did not get through the coarse step (" +
                              (!(h > 1e-18)
                                   ? "the sub-step fell below 1e-18 s"
                                   : "more than " + std::to_string(kMaxSubsteps) + " sub-steps") +
                              " at " + std::to_string(tau / H) + " of it)");
    // The last sub-step lands on H; one just short of it is stretched.
    if (tau + h >= H || H - (tau + h) < 1e-3 * h) h = H - tau;
    z[0] = x;
    f[0] = out.points.back().f;
    ac[0] = a;
    if (!stages(j, coupling, forcing, tau, h, z, f, ac)) {
      ++out.rejected;
      h *= 0.25;
      continue;
    }
    const double error = error_norm(h, x, f);
    if (!(error <= 1.0)) {
      ++out.rejected;
      h *= std::isfinite(error) ? std::clamp(0.9 * std::pow(error, exponent), 0.1, 0.9) : 0.25;
      continue;
    }
    double dissipated = out.points.back().dissipated;
    for (int l = 0; l < s; ++l) {
      const double wb = h * table_.b[l], tl = tau + table_.c[l] * h;
      for (int k = 0; k < 2; ++k) {
        out.impulse[k] += wb * ac[l][k];
        out.moment[k] += wb * tl * ac[l][k];
        const double own = ac[l][k] + K * z[l][k] + C * z[l][2 + k];
        out.own_impulse[k] += wb * own;
        out.own_moment[k] += wb * tl * own;
      }
      dissipated -= wb * m * (ac[l][0] * z[l][2] + ac[l][1] * z[l][3]);
    }
    x = z[s - 1];
    a = ac[s - 1];
    tau += h;
    if (H - tau < 1e-12 * H) tau = H;
    out.points.push_back({tau, x, f[s - 1], dissipated});
    ++out.substeps;
    h *= std::clamp(0.9 * std::pow(std::max(error, 1e-10), exponent), 0.2, 5.0);
  }
  out.contact_acceleration = a;
  out.last_substep = h;
  return out;
}

}  // namespace stickslip
