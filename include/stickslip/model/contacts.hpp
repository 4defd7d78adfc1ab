#pragma once
// Where the contacts sit on the bottom layer and their v* (MODEL.md §6).

#include <cstdint>
#include <vector>

#include "stickslip/case/case.hpp"

namespace stickslip {

struct Contact {
  int ix = 0;
  int iy = 0;
  double v_star = 0.0;  // [m/s]
};

// N_c = round-half-up(θ Nx Ny).
int contact_count(double coverage, int nx, int ny);

// The explicit list of the case, or N_c distinct sites drawn uniformly without
// replacement followed by log10 v* uniform in [log10 v_m − δ, log10 v_m + δ],
// all from one generator seeded with `seed`. Bit-identical on every build:
// std::mt19937_64's raw output is fixed by the standard and the conversions to
// integers and reals below are our own (std::uniform_*_distribution's are not portable).
std::vector<Contact> place_contacts(const LatticeParams& lattice, const InterfaceParams& iface);

}  // namespace stickslip
