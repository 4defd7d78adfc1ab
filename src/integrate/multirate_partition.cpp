#include "stickslip/integrate/multirate_partition.hpp"

#include <algorithm>
#include <cmath>

namespace stickslip {

namespace {

// Per site: 1 where at most `neighbours` of the eight sites around it
// (periodic in x and y) hold a contact.
std::vector<char> lone_sites(const System& s, int neighbours) {
  const int nx = s.nx(), ny = s.ny();
  std::vector<char> occupied(static_cast<std::size_t>(nx) * ny, 0);
  for (const FrictionSite& site : s.contact_set().sites())
    occupied[static_cast<std::size_t>(site.ix + nx * site.iy)] = 1;
  std::vector<char> lone(s.contact_set().sites().size());
  for (std::size_t j = 0; j < lone.size(); ++j) {
    const FrictionSite& site = s.contact_set().sites()[j];
    int count = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const int x = (site.ix + dx + nx) % nx, y = (site.iy + dy + ny) % ny;
        if ((x != site.ix || y != site.iy) && occupied[static_cast<std::size_t>(x + nx * y)])
          ++count;
      }
    lone[j] = count <= neighbours;
  }
  return lone;
}

}  // namespace

std::vector<long> MultiratePartition::contact_weights(const System& system, long min_fast) {
  const std::vector<char> lone = lone_sites(system, kLoneNeighbours);
  const auto lone_count = std::count(lone.begin(), lone.end(), char{1});
  const auto others = static_cast<long>(lone.size()) - lone_count;
  const bool one_goes_apart = 2 * lone_count >= static_cast<long>(lone.size()) &&
                              kLoneShare * lone_count + others >= min_fast;
  std::vector<long> weight(lone.size());
  for (std::size_t j = 0; j < lone.size(); ++j)
    weight[j] = lone[j] ? (one_goes_apart ? min_fast : kLoneShare) : 1;
  return weight;
}

MultiratePartition::MultiratePartition(const System& system, long min_fast)
    : system_(system),
      min_fast_(min_fast),
      weight_(contact_weights(system, min_fast)),
      forced_fast_(system.contact_set().sites().size(), 0) {}

std::vector<std::size_t> MultiratePartition::fast_contacts(
    double H, std::span<const double> y, std::span<const double> lattice_f,
    std::span<const std::array<double, 2>> contact_a, bool after_step_apart) const {
  std::vector<std::size_t> fast;
  for (std::size_t j = 0; j < contact_a.size(); ++j) {
    const auto wx = system_.w_index(system_.contact_set().sites()[j].node, 0);
    const double sx = y[wx], sy = y[wx + 1];
    const double speed2 = sx * sx + sy * sy;
    bool is_fast = forced_fast_[j] > 0 || system_.contact_set().slipping(j, y);
    if (!is_fast && speed2 > 0.0) {
      const double ax = lattice_f[wx] + contact_a[j][0];
      const double ay = lattice_f[wx + 1] + contact_a[j][1];
      is_fast = std::abs(sx * ax + sy * ay) / speed2 * H > 1.0;
    }
    if (is_fast) fast.push_back(j);
  }
  const long fewest = after_step_apart ? std::max<long>(1, min_fast_ / kStayApart) : min_fast_;
  long count = 0;
  for (const std::size_t j : fast) count += weight_[j];
  if (count < fewest) fast.clear();
  return fast;
}

void MultiratePartition::step_accepted() {
  for (auto& hold : forced_fast_) hold = hold > 0 ? hold - 1 : 0;
}

}  // namespace stickslip
