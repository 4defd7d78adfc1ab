#include "stickslip/model/contacts.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace stickslip {

ContactSet::ContactSet(const InterfaceParams& iface, std::vector<Contact> contacts, int nx, int ny,
                       std::int64_t nodes, double mass, double force_scale, double eta_c)
    : nodes_(nodes),
      mass_(mass),
      slip_threshold_(iface.slip_threshold),
      law_(make_contact_law(iface, force_scale, eta_c)),
      contacts_(std::move(contacts)),
      patch_(iface.patch) {
  if (patch_ < 1 || patch_ > std::min(nx, ny))
    throw std::invalid_argument("patch size outside [1, min(nx, ny)]");
  if (first_overlap(contacts_, patch_, nx, ny))
    throw std::invalid_argument("contact patches overlap");
  for (const auto& ct : contacts_) {
    if (ct.ix < 0 || ct.ix >= nx || ct.iy < 0 || ct.iy >= ny || !(ct.v_star > 0.0))
      throw std::invalid_argument("contact outside the bottom layer or with v* <= 0");
    const double scale = with_law([&](const auto& law) { return law.speed_scale(ct); });
    for (const auto& [x, y] : patch_sites(ct.ix, ct.iy, patch_, nx, ny))
      sites_.push_back({x, y, x + std::int64_t{nx} * y, scale});  // node (x, y, 0)
  }
}

double ContactSet::speed_scale(std::size_t i) const {
  return with_law([&](const auto& law) { return law.speed_scale(contacts_[i]); });
}

double ContactSet::stick_slip_root(std::size_t i, double speed) const {
  return with_law([&](const auto& law) { return law.stick_slip_root(speed, speed_scale(i)); });
}

void ContactSet::stick_slip_roots(std::span<const double> y, std::span<const int> watched,
                                  std::span<double> g) const {
  for (std::size_t k = 0; k < watched.size(); ++k) {
    const auto i = static_cast<std::size_t>(watched[k]);
    g[k] = stick_slip_root(i, contact_speed(i, y));
  }
}

bool ContactSet::slipping(std::size_t i, std::span<const double> y) const {
  const auto s = contact_velocity(i, y);
  return with_law(
      [&](const auto& law) { return law.slips(std::hypot(s[0], s[1]), speed_scale(i)); });
}

std::array<double, 2> ContactSet::site_acceleration(std::size_t j, std::array<double, 2> s) const {
  return with_law([&](const auto& law) { return law.acceleration(sites_[j].v_star, s); });
}

std::array<double, 4> ContactSet::site_block(std::size_t j, std::span<const double> y) const {
  const auto s = site_velocity(j, y);
  return with_law([&](const auto& law) { return law.jacobian(sites_[j].v_star, s); });
}

// The law solves it (SpeedLaw::stage for the paper's: Newton in log-speed,
// model/friction_law.hpp).
ContactStage ContactSet::site_stage(std::size_t j, double gamma, std::array<double, 2> b,
                                    double predictor_speed, bool derivative) const {
  return with_law([&](const auto& law) {
    return law.stage(sites_[j].v_star, gamma, b, predictor_speed, derivative);
  });
}

long ContactSet::solve_implicit_stage(double gamma, std::span<const double> predictor,
                                      std::span<double> z) const {
  long iterations = 0;
  with_law([&](const auto& law) {
    for (std::size_t j = 0; j < sites_.size(); ++j) {
      const std::int64_t wx = w_index(sites_[j].node);
      const ContactStage c = law.stage(sites_[j].v_star, gamma, {z[wx], z[wx + 1]},
                                       std::hypot(predictor[wx], predictor[wx + 1]), false);
      iterations += c.iterations;
      z[wx] = c.s[0];
      z[wx + 1] = c.s[1];
    }
  });
  return iterations;
}

void ContactSet::add_accelerations(std::span<const double> y, std::span<double> ydot) const {
  with_law([&](const auto& law) {
    for (std::size_t j = 0; j < sites_.size(); ++j) {
      const auto a = law.acceleration(sites_[j].v_star, site_velocity(j, y));
      const std::int64_t wx = w_index(sites_[j].node);
      ydot[wx] += a[0];
      ydot[wx + 1] += a[1];
    }
  });
}

void ContactSet::add_jacobian_blocks(std::span<const double> y,
                                     const std::vector<std::array<std::int64_t, 4>>& slot,
                                     std::vector<double>& value) const {
  with_law([&](const auto& law) {
    for (std::size_t j = 0; j < sites_.size(); ++j) {
      const auto block = law.jacobian(sites_[j].v_star, site_velocity(j, y));
      for (int k = 0; k < 4; ++k) value[slot[j][k]] += block[k];
    }
  });
}

// ε f0 φ |s| + m η_c |s|² = −m a·s for each contact.
double ContactSet::dissipation(std::span<const double> y) const {
  double sum = 0.0;
  with_law([&](const auto& law) {
    for (std::size_t j = 0; j < sites_.size(); ++j) {
      const auto s = site_velocity(j, y);
      const auto a = law.acceleration(sites_[j].v_star, s);
      sum -= a[0] * s[0] + a[1] * s[1];
    }
  });
  return mass_ * sum;
}

double ContactSet::total_force_x(std::span<const double> y) const {
  double sum = 0.0;
  for (std::size_t j = 0; j < sites_.size(); ++j)
    sum += site_acceleration(j, site_velocity(j, y))[0];
  return mass_ * sum;
}

double ContactSet::contact_force(std::size_t i, std::span<const double> y) const {
  std::array<double, 2> sum{};
  const std::size_t first = i * sites_of(i).size();
  for (std::size_t j = first; j < first + sites_of(i).size(); ++j) {
    const auto a = site_acceleration(j, site_velocity(j, y));
    sum[0] += a[0];
    sum[1] += a[1];
  }
  return mass_ * std::hypot(sum[0], sum[1]);
}

std::array<double, 2> ContactSet::contact_velocity(std::size_t i, std::span<const double> y) const {
  const auto sites = sites_of(i);
  if (sites.size() == 1) return site_velocity(i, y);  // R = 1: no rounding by the mean
  std::array<double, 2> mean{};
  for (const auto& site : sites) {
    const std::int64_t wx = w_index(site.node);
    mean[0] += y[wx];
    mean[1] += y[wx + 1];
  }
  const double n = static_cast<double>(sites.size());
  return {mean[0] / n, mean[1] / n};
}

double ContactSet::contact_speed(std::size_t i, std::span<const double> y) const {
  const auto s = contact_velocity(i, y);
  return std::hypot(s[0], s[1]);
}

std::array<double, 2> ContactSet::contact_displacement(std::size_t i,
                                                       std::span<const double> y) const {
  const auto sites = sites_of(i);
  std::array<double, 2> mean{};
  for (const auto& site : sites) {
    const std::int64_t ux = u_index(site.node);
    mean[0] += y[ux];
    mean[1] += y[ux + 1];
  }
  const double n = static_cast<double>(sites.size());
  return {mean[0] / n, mean[1] / n};
}

double ContactSet::contact_load(std::size_t i, std::span<const double> acc) const {
  std::array<double, 2> sum{};
  for (const auto& site : sites_of(i)) {
    sum[0] += acc[static_cast<std::size_t>(3 * site.node)];
    sum[1] += acc[static_cast<std::size_t>(3 * site.node + 1)];
  }
  return mass_ * std::hypot(sum[0], sum[1]);
}

double ContactSet::weakening_rate(std::span<const double> y) const {
  double rate = 0.0;
  for (std::size_t j = 0; j < sites_.size(); ++j)
    rate = std::max(rate, site_weakening_rate(j, site_velocity(j, y)));
  return rate;
}

double ContactSet::site_weakening_rate(std::size_t j, std::array<double, 2> s) const {
  const double speed = std::hypot(s[0], s[1]);
  if (!(speed > 0.0)) return 0.0;  // at rest the force rises with speed
  // The Jacobian block along ŝ: ∂a/∂|s|, positive past the peak.
  const auto b = with_law([&](const auto& law) { return law.jacobian(sites_[j].v_star, s); });
  const double nx = s[0] / speed, ny = s[1] / speed;
  return std::max(0.0, nx * (b[0] * nx + b[1] * ny) + ny * (b[2] * nx + b[3] * ny));
}

double ContactSet::site_damping_rate(std::size_t j, std::array<double, 2> s) const {
  const auto b = with_law([&](const auto& law) { return law.jacobian(sites_[j].v_star, s); });
  const double speed = std::hypot(s[0], s[1]);
  if (!(speed > 0.0)) return -std::max(b[0], b[3]);  // isotropic at rest
  const double nx = s[0] / speed, ny = s[1] / speed;
  const double radial = nx * (b[0] * nx + b[1] * ny) + ny * (b[2] * nx + b[3] * ny);
  const double tangential = ny * (b[0] * ny - b[1] * nx) - nx * (b[2] * ny - b[3] * nx);
  return -std::max(radial, tangential);
}

double ContactSet::mean_steady_phi(double speed) const {
  double mean_phi = 0.0;
  with_law([&](const auto& law) {
    for (const auto& c : contacts_) mean_phi += law.steady_phi(speed, law.speed_scale(c));
  });
  return mean_phi / static_cast<double>(contacts_.size());
}

}  // namespace stickslip
