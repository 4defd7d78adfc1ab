#include "stickslip/case/placement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <string>

namespace stickslip {
namespace {

// Uniform integer in [0, n) by rejection, so every value is equally likely.
std::uint64_t uniform_below(std::mt19937_64& gen, std::uint64_t n) {
  const std::uint64_t limit =
      std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % n;
  std::uint64_t x;
  do {
    x = gen();
  } while (x >= limit);
  return x % n;
}

// Uniform real in [0, 1) from the top 53 bits.
double uniform_unit(std::mt19937_64& gen) {
  return static_cast<double>(gen() >> 11) * 0x1.0p-53;
}

}  // namespace

int contact_count(double coverage, int nx, int ny, int patch) {
  return static_cast<int>(std::floor(coverage * nx * ny / (double(patch) * patch) + 0.5));
}

double realized_coverage(const LatticeParams& lattice, const InterfaceParams& iface) {
  const int nx = lattice.nx, ny = lattice.ny, patch = iface.patch;
  const double count = iface.contacts.empty() ? contact_count(iface.coverage, nx, ny, patch)
                                              : static_cast<double>(iface.contacts.size());
  return count * patch * patch / (static_cast<double>(nx) * ny);
}

std::vector<std::array<int, 2>> patch_sites(int ix, int iy, int patch, int nx, int ny) {
  std::vector<std::array<int, 2>> sites;
  sites.reserve(static_cast<std::size_t>(patch) * patch);
  for (int dy = 0; dy < patch; ++dy)
    for (int dx = 0; dx < patch; ++dx) sites.push_back({(ix + dx) % nx, (iy + dy) % ny});
  return sites;
}

std::optional<std::pair<std::size_t, std::size_t>> first_overlap(const std::vector<Contact>& c,
                                                                 int patch, int nx, int ny) {
  constexpr std::size_t kFree = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> owner(static_cast<std::size_t>(nx) * ny, kFree);
  for (std::size_t j = 0; j < c.size(); ++j)
    for (const auto& [x, y] : patch_sites(c[j].ix, c[j].iy, patch, nx, ny)) {
      std::size_t& o = owner[static_cast<std::size_t>(x + nx * y)];
      if (o != kFree) return std::pair{o, j};
      o = j;
    }
  return std::nullopt;
}

std::vector<Contact> place_contacts(const LatticeParams& lattice, const InterfaceParams& iface) {
  std::vector<Contact> contacts;
  if (!iface.contacts.empty()) {
    for (const auto& c : iface.contacts) contacts.push_back({c.ix, c.iy, c.v_star});
    return contacts;
  }
  const int nx = lattice.nx, ny = lattice.ny, patch = iface.patch;
  const int corners = nx * ny;
  const int count = contact_count(iface.coverage, nx, ny, patch);
  std::mt19937_64 gen(iface.seed);
  // Partial Fisher–Yates: corner[0..k) is a uniform sample without
  // replacement, in drawing order; the accepted ones are the contacts.
  std::vector<int> corner(corners);
  std::iota(corner.begin(), corner.end(), 0);
  std::vector<char> covered(static_cast<std::size_t>(corners), 0);
  std::vector<int> accepted;
  for (int k = 0; k < corners && static_cast<int>(accepted.size()) < count; ++k) {
    const int j = k + static_cast<int>(uniform_below(gen, static_cast<std::uint64_t>(corners - k)));
    std::swap(corner[k], corner[j]);
    const auto sites = patch_sites(corner[k] % nx, corner[k] / nx, patch, nx, ny);
    if (std::any_of(sites.begin(), sites.end(),
                    [&](const auto& s) { return covered[s[0] + nx * s[1]] != 0; }))
      continue;
    for (const auto& s : sites) covered[s[0] + nx * s[1]] = 1;
    accepted.push_back(corner[k]);
  }
  if (static_cast<int>(accepted.size()) < count)
    throw PlacementError("only " + std::to_string(accepted.size()) + " of " +
                         std::to_string(count) + " non-overlapping " + std::to_string(patch) + "x" +
                         std::to_string(patch) + " patches fit on the " + std::to_string(nx) + "x" +
                         std::to_string(ny) + " interface with seed " + std::to_string(iface.seed));
  const double log_lo = std::log10(iface.v_m) - iface.spread;
  for (const int c : accepted) {
    const double log_v = log_lo + 2.0 * iface.spread * uniform_unit(gen);
    contacts.push_back({c % nx, c / nx, std::pow(10.0, log_v)});
  }
  return contacts;
}

}  // namespace stickslip
