#include "stickslip/model/contacts.hpp"

#include <cmath>
#include <numeric>
#include <random>

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

int contact_count(double coverage, int nx, int ny) {
  return static_cast<int>(std::floor(coverage * nx * ny + 0.5));
}

std::vector<Contact> place_contacts(const LatticeParams& lattice, const InterfaceParams& iface) {
  std::vector<Contact> contacts;
  if (!iface.contacts.empty()) {
    for (const auto& c : iface.contacts) contacts.push_back({c.ix, c.iy, c.v_star});
    return contacts;
  }
  const int sites = lattice.nx * lattice.ny;
  const int count = contact_count(iface.coverage, lattice.nx, lattice.ny);
  std::mt19937_64 gen(iface.seed);
  // Partial Fisher–Yates: the first `count` entries become a uniform sample
  // without replacement, in drawing order.
  std::vector<int> site(sites);
  std::iota(site.begin(), site.end(), 0);
  for (int k = 0; k < count; ++k) {
    const int j = k + static_cast<int>(uniform_below(gen, static_cast<std::uint64_t>(sites - k)));
    std::swap(site[k], site[j]);
  }
  const double log_lo = std::log10(iface.v_m) - iface.spread;
  for (int k = 0; k < count; ++k) {
    const double log_v = log_lo + 2.0 * iface.spread * uniform_unit(gen);
    contacts.push_back({site[k] % lattice.nx, site[k] / lattice.nx, std::pow(10.0, log_v)});
  }
  return contacts;
}

}  // namespace stickslip
