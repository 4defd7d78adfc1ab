// Finite-size asperities (MODEL.md §14): R×R patches of bottom nodes, each node
// carrying the contact law with the patch's v*, stick and slip on the patch's
// mean velocity, and steady sliding's exact μ with θ the covered fraction.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "stickslip/case/placement.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/run/run.hpp"
#include "temp_dir.hpp"
#include "test_cases.hpp"

using namespace stickslip;

TEST_CASE("patch count: round half up of theta Nx Ny / R^2", "[patches]") {
  CHECK(contact_count(0.5, 30, 30, 3) == 50);  // 50.0
  CHECK(contact_count(0.5, 15, 15, 2) == 28);  // 28.125
  CHECK(contact_count(0.5, 6, 6, 2) == 5);     // 4.5 → 5
  CHECK(contact_count(0.5, 15, 15, 1) == contact_count(0.5, 15, 15));
}

TEST_CASE("a patch wraps around the interface, and overlaps are found across the seam",
          "[patches]") {
  const auto sites = patch_sites(5, 4, 2, 6, 5);
  const std::vector<std::array<int, 2>> expected = {{5, 4}, {0, 4}, {5, 0}, {0, 0}};
  CHECK(sites == expected);
  // A 3×3 patch at (13, 13) on 15×15 covers (0, 0) but not (1, 1).
  CHECK(first_overlap({{13, 13, 1e-3}, {1, 1, 1e-3}}, 3, 15, 15) == std::nullopt);
  const auto overlap = first_overlap({{1, 1, 1e-3}, {13, 13, 1e-3}, {0, 0, 1e-3}}, 3, 15, 15);
  REQUIRE(overlap);
  CHECK(overlap->first == 1);  // node (0, 0), the first of contact 2's, is contact 1's
  CHECK(overlap->second == 2);
}

TEST_CASE("random patches: N_c of them, disjoint, reproducible, too many is an error",
          "[patches]") {
  LatticeParams lattice{30, 30, 10, 1e-4};
  InterfaceParams iface;
  iface.coverage = 0.5;
  iface.patch = 3;
  iface.seed = 5;
  const auto a = place_contacts(lattice, iface);
  REQUIRE(a.size() == 50);
  CHECK_FALSE(first_overlap(a, 3, 30, 30));
  std::set<std::pair<int, int>> covered;
  for (const auto& c : a)
    for (const auto& s : patch_sites(c.ix, c.iy, 3, 30, 30)) covered.insert({s[0], s[1]});
  CHECK(covered.size() == 450);  // θ = 0.5 exactly
  const auto b = place_contacts(lattice, iface);
  for (std::size_t i = 0; i < a.size(); ++i)
    CHECK((a[i].ix == b[i].ix && a[i].iy == b[i].iy && a[i].v_star == b[i].v_star));

  // Two 3×3 patches need 18 nodes; a 4×4 interface has 16.
  lattice = {4, 4, 2, 1e-4};
  iface.coverage = 1.0;  // round(16/9) = 2
  REQUIRE_THROWS_AS(place_contacts(lattice, iface), PlacementError);
}

TEST_CASE("every site of a patch carries the contact law, the patch moves at their mean",
          "[patches]") {
  Case c;
  c.lattice = {6, 6, 3, 1e-4};
  c.interface.patch = 2;
  const double v_star = 4e-4;
  const System s(c, {{5, 5, v_star}, {2, 2, 2e-3}});  // the first wraps to (0, 0)
  REQUIRE(s.contact_set().sites().size() == 8);
  CHECK(s.coverage() == Approx(8.0 / 36).epsilon(1e-15));
  // F_N = ε θ P0 Nx Ny a² with θ = 8/36.
  const auto& i = c.interface;
  CHECK(s.normal_force() ==
        Approx(i.epsilon * 8 * i.max_pressure * c.lattice.spacing * c.lattice.spacing)
            .epsilon(1e-15));
  std::set<std::int64_t> nodes;
  for (const auto& site : s.contact_set().sites_of(0)) nodes.insert(site.node);
  CHECK(nodes ==
        std::set<std::int64_t>{s.node(5, 5, 0), s.node(0, 5, 0), s.node(5, 0, 0), s.node(0, 0, 0)});

  // Four different site velocities on patch 0.
  std::vector<double> y(static_cast<std::size_t>(s.size()), 0.0);
  const double vx[4] = {1e-4, 3e-4, -2e-4, 9e-4}, vy[4] = {0.0, 2e-4, 1e-4, -5e-4};
  const auto sites = s.contact_set().sites_of(0);
  for (std::size_t k = 0; k < 4; ++k) {
    y[s.w_index(sites[k].node, 0)] = vx[k];
    y[s.w_index(sites[k].node, 1)] = vy[k];
  }
  const auto mean = s.contact_set().contact_velocity(0, y);
  CHECK(mean[0] == Approx(2.75e-4).epsilon(1e-14));
  CHECK(mean[1] == Approx(-0.5e-4).epsilon(1e-14));
  // Stick/slip on the mean speed: 2.795e-4 < v*, though one site moves at 1e-3.
  double g = 0.0;
  const int watched[1] = {0};
  s.contact_set().stick_slip_roots(y, watched, std::span(&g, 1));
  CHECK(g == Approx(std::hypot(2.75e-4, -0.5e-4) - v_star).epsilon(1e-14));
  CHECK_FALSE(s.contact_set().slipping(0, y));
  // The same root from the contact's speed alone (how the multirate stepper
  // asks between its sub-steps), bit for bit; and the law's speed scale.
  CHECK(s.contact_set().stick_slip_root(0, s.contact_set().contact_speed(0, y)) == g);
  CHECK(s.contact_set().stick_slip_root(0, 2 * v_star) == Approx(v_star).epsilon(1e-15));
  CHECK(s.contact_set().speed_scale(0) == v_star);
  CHECK(s.contact_set().speed_scale(1) == 2e-3);

  // Each site's force is that of a single-site contact (R = 1) with the patch's
  // v* at the same node and velocity; the patch's force is their sum.
  Case single = c;
  single.interface.patch = 1;
  std::vector<double> implicit(y.size()), alone(y.size());
  s.rhs_implicit(0.0, y, implicit);
  double sum_x = 0.0, sum_y = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    const System one(single, {{sites[k].ix, sites[k].iy, v_star}});
    one.rhs_implicit(0.0, y, alone);
    for (int d = 0; d < 2; ++d)
      CHECK(implicit[s.w_index(sites[k].node, d)] == alone[one.w_index(sites[k].node, d)]);
    sum_x += one.mass() * alone[one.w_index(sites[k].node, 0)];
    sum_y += one.mass() * alone[one.w_index(sites[k].node, 1)];
    CHECK(alone[one.w_index(sites[k].node, 0)] != 0.0);
  }
  CHECK(s.contact_set().contact_force(0, y) == Approx(std::hypot(sum_x, sum_y)).epsilon(1e-14));
  // Nothing else feels a contact force: patch 1's sites are at rest, other nodes carry none.
  double elsewhere = 0.0;
  for (std::size_t r = 0; r < implicit.size(); ++r) elsewhere += std::abs(implicit[r]);
  for (std::size_t k = 0; k < 4; ++k)
    for (int d = 0; d < 2; ++d) elsewhere -= std::abs(implicit[s.w_index(sites[k].node, d)]);
  CHECK(elsewhere == Approx(0.0).margin(1e-300));
}

TEST_CASE("with 2x2 patches, cases/steady.toml reaches the exact steady-sliding mu",
          "[patches][steady]") {
  Case c = read_case(std::filesystem::path(STICKSLIP_SOURCE_DIR) / "cases/steady.toml");
  c.interface.patch = 2;
  const auto contacts = place_contacts(c.lattice, c.interface);
  REQUIRE(contacts.size() == 5);  // round(0.5 · 36 / 4): 20 of 36 nodes covered
  for (const auto& ct : contacts) REQUIRE(ct.v_star >= 3 * c.drive.velocity);

  // MODEL.md §7 and §14: the mean over patches.
  const double exact = stickslip::test::steady_sliding_mu_exact(c, contacts);

  RunOptions options;
  const test::TempDir tmp("stickslip_test_patch_steady");
  options.out_dir = tmp.path / "out";
  options.overwrite = true;
  options.quiet = true;
  const Summary r = run_case(c, options);
  const auto summary = nlohmann::json::parse(std::ifstream(options.out_dir / "summary.json"));
  INFO("mu = " << r.mu << ", exact " << exact);
  CHECK(std::abs(r.mu / exact - 1) < 5e-3);
  CHECK(summary.at("theta").get<double>() == Approx(20.0 / 36).epsilon(1e-15));
  CHECK(std::abs(r.energy_residual) < 1e-5);
}
