#pragma once
// Cases and systems more than one test file builds.
#include "stickslip/case/case.hpp"
#include "stickslip/case/placement.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip::test {

// The Fig. 10b pair (v* 4.75e-4 and 2.09e-3) on a 6×6×4 lattice.
inline Case two_contact_case() {
  Case c;
  c.lattice = {6, 6, 4, 1e-4};
  c.interface.contacts = {{1, 2, 4.75e-4, 0}, {4, 2, 2.09e-3, 0}};
  return c;
}

// The same pair as the sections of a case file, for tests that write one.
inline constexpr const char* kTwoContactToml = R"([lattice]
nx = 6
ny = 6
nz = 4
[interface]
contacts = [ { site = [1, 2], v_star = 4.75e-4 }, { site = [4, 2], v_star = 2.09e-3 } ]
)";

inline System make_system(const Case& c) {
  return System(c, place_contacts(c.lattice, c.interface));
}

}  // namespace stickslip::test
