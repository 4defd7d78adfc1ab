#pragma once
// Where the contacts sit on the bottom layer and their v* (MODEL.md §6, §14).
// A contact is an R×R patch of bottom nodes (R = [interface] patch, 1 for the
// paper's single sites), wrapping periodically, named by its corner (ix, iy).

#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "stickslip/case/case.hpp"

namespace stickslip {

struct Contact {
  int ix = 0;
  int iy = 0;
  double v_star = 0.0;  // [m/s]
};

// N_c = round-half-up(θ Nx Ny / R²).
int contact_count(double coverage, int nx, int ny, int patch = 1);

// θ as placed: the contacts' bottom nodes over the interface's Nx Ny (the
// explicit list's contacts, or N_c patches, each of R² nodes).
double realized_coverage(const LatticeParams& lattice, const InterfaceParams& iface);

// The bottom sites (ix, iy) of the R×R patch with corner (ix, iy), row by row.
std::vector<std::array<int, 2>> patch_sites(int ix, int iy, int patch, int nx, int ny);

// The first pair (i, j), i < j, of contacts whose patches share a node.
std::optional<std::pair<std::size_t, std::size_t>> first_overlap(const std::vector<Contact>& c,
                                                                 int patch, int nx, int ny);

// Random placement ran out of corners before N_c patches fitted.
struct PlacementError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The explicit list of the case, or N_c non-overlapping patches followed by
// log10 v* uniform in [log10 v_m − δ, log10 v_m + δ], all from one generator
// seeded with `seed`. Corners are drawn uniformly without replacement, and a
// corner whose patch would touch a placed patch is passed over (for R = 1
// none is, so every site is as likely). Bit-identical on every build:
// std::mt19937_64's raw output is fixed by the standard and the conversions
// to integers and reals below are our own (std::uniform_*_distribution's are
// not portable). Throws PlacementError when the corners run out.
std::vector<Contact> place_contacts(const LatticeParams& lattice, const InterfaceParams& iface);

}  // namespace stickslip
