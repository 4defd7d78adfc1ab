// Random contact placement (MODEL.md §6).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <set>

#include "stickslip/case/placement.hpp"

using namespace stickslip;

TEST_CASE("contact count rounds half up", "[contacts]") {
  CHECK(contact_count(0.5, 15, 15) == 113);  // 112.5 → 113
  CHECK(contact_count(0.04, 15, 15) == 9);   // 9.0
  CHECK(contact_count(1.0, 30, 30) == 900);
  CHECK(contact_count(0.001, 15, 15) == 0);
}

TEST_CASE("the generator's raw output is the one the C++ standard fixes", "[contacts]") {
  // [rand.predef]: the 10000th output of a default-constructed mt19937_64.
  std::mt19937_64 gen;
  gen.discard(9999);
  CHECK(gen() == 9981545732273789042ull);
}

TEST_CASE("random placement: distinct sites, v* in range, reproducible from the seed",
          "[contacts]") {
  LatticeParams lattice;
  InterfaceParams iface;
  iface.coverage = 0.5;
  iface.seed = 42;
  const auto a = place_contacts(lattice, iface);
  const auto b = place_contacts(lattice, iface);
  REQUIRE(a.size() == 113);
  std::set<std::pair<int, int>> sites;
  for (std::size_t i = 0; i < a.size(); ++i) {
    CHECK(a[i].ix == b[i].ix);
    CHECK(a[i].iy == b[i].iy);
    CHECK(a[i].v_star == b[i].v_star);  // bit for bit
    CHECK(a[i].ix >= 0);
    CHECK(a[i].ix < 15);
    CHECK(a[i].iy >= 0);
    CHECK(a[i].iy < 15);
    CHECK(std::log10(a[i].v_star) >= -3.5 - 1e-12);
    CHECK(std::log10(a[i].v_star) <= -2.5 + 1e-12);
    sites.insert({a[i].ix, a[i].iy});
  }
  CHECK(sites.size() == a.size());
  iface.seed = 43;
  const auto c = place_contacts(lattice, iface);
  int same = 0;
  for (std::size_t i = 0; i < a.size(); ++i) same += (a[i].ix == c[i].ix && a[i].iy == c[i].iy);
  CHECK(same < 20);
}

TEST_CASE("full coverage uses every site once", "[contacts]") {
  LatticeParams lattice{6, 5, 3, 1e-4};
  InterfaceParams iface;
  iface.coverage = 1.0;
  const auto all = place_contacts(lattice, iface);
  std::set<std::pair<int, int>> sites;
  for (const auto& c : all) sites.insert({c.ix, c.iy});
  CHECK(sites.size() == 30);
}

TEST_CASE("an explicit list is used as given, in order", "[contacts]") {
  LatticeParams lattice;
  InterfaceParams iface;
  iface.contacts = {{4, 7, 4.75e-4, 0}, {11, 7, 2.09e-3, 0}};
  const auto c = place_contacts(lattice, iface);
  REQUIRE(c.size() == 2);
  CHECK(c[0].ix == 4);
  CHECK(c[1].ix == 11);
  CHECK(c[1].v_star == 2.09e-3);
}
