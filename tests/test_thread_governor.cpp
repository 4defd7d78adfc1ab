// ThreadGovernor: when a run's threads wait for cores, it goes on one thread
// and tries its threads again after a backoff; and changing the loops'
// threads between steps does not change a result.
#include <catch2/catch.hpp>
#include <optional>
#include <vector>

#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/run/thread_governor.hpp"
#include "test_cases.hpp"

using namespace stickslip;

namespace {
using G = ThreadGovernor;

// The governor fed a clock that advances by `step` seconds a call, its threads
// having waited `wait_share` of each second per thread while all are in use.
struct Machine {
  G governor;
  double wall = 0.0, waited = 0.0;
  int update(double step, double wait_share) {
    waited += wait_share * governor.threads() * step;
    wall += step;
    return governor.update(wall, [&] { return std::optional<double>(waited); });
  }
};
}  // namespace

TEST_CASE("thread governor: threads that get their cores are kept", "[thread_governor]") {
  Machine m{G(2)};
  for (int k = 0; k < 1000; ++k) CHECK(m.update(0.1, 0.9 * G::kMaxWait) == 2);
  CHECK(m.governor.lowered_seconds(m.wall) == 0.0);
}

TEST_CASE("thread governor: waiting threads go down to one, tried again after a doubling backoff",
          "[thread_governor]") {
  Machine m{G(4)};
  m.update(0.1, 0.0);  // the first call starts the first window
  // A whole window of waits above kMaxWait per thread: one thread from its end.
  double lowered_at = 0.0;
  for (int k = 0; k < 100 && m.governor.threads() == 4; ++k) {
    m.update(0.1, 1.1 * G::kMaxWait);
    lowered_at = m.wall;
  }
  REQUIRE(m.governor.threads() == 1);
  CHECK(lowered_at == Approx(0.1 + G::kWindow));
  // One thread until the backoff has passed (waits on one thread are not judged).
  while (m.wall < lowered_at + G::kFirstBackoff - 0.15) CHECK(m.update(0.1, 1.0) == 1);
  // Then all four again, at the first window's end past the backoff.
  double restored_at = 0.0;
  for (int k = 0; k < 20 && m.governor.threads() == 1; ++k) {
    m.update(0.1, 1.1 * G::kMaxWait);
    restored_at = m.wall;
  }
  REQUIRE(m.governor.threads() == 4);
  CHECK(restored_at >= lowered_at + G::kFirstBackoff);
  CHECK(restored_at < lowered_at + G::kFirstBackoff + G::kWindow + 0.15);
  CHECK(m.governor.lowered_seconds(m.wall) == Approx(restored_at - lowered_at));
  // Still waiting: down again, now for twice as long.
  double lowered_again = 0.0;
  for (int k = 0; k < 100 && m.governor.threads() == 4; ++k) {
    m.update(0.1, 1.1 * G::kMaxWait);
    lowered_again = m.wall;
  }
  REQUIRE(m.governor.threads() == 1);
  while (m.wall < lowered_again + 2 * G::kFirstBackoff - 0.15) CHECK(m.update(0.1, 0.0) == 1);
  // The lowered time counts up to now while it lasts.
  CHECK(m.governor.lowered_seconds(m.wall) ==
        Approx(restored_at - lowered_at + m.wall - lowered_again));
}

TEST_CASE("thread governor: one thread, or waits the kernel does not keep, change nothing",
          "[thread_governor]") {
  G single(1);
  for (double wall = 0.0; wall < 10.0; wall += 0.1)
    CHECK(single.update(wall, [] { return std::optional<double>(1e9); }) == 1);
  G unknown(2);
  for (double wall = 0.0; wall < 10.0; wall += 0.1)
    CHECK(unknown.update(wall, [] { return std::optional<double>(); }) == 2);
}

TEST_CASE("the loops' threads changed between steps leave the result as it is, bit for bit",
          "[thread_governor][threads]") {
  // The pair on a lattice wide enough for the FFTs' plans per layer, so the
  // modes, layers and contacts all split over threads.
  Case c = test::two_contact_case();
  c.lattice = {32, 32, 3, 1e-4};
  c.solver.method = Method::dirk;
  std::vector<std::vector<double>> finals;
  for (const bool alternate : {false, true}) {
    c.solver.threads = alternate ? 3 : 1;
    const System s = test::make_system(c);
    std::vector<double> y(static_cast<std::size_t>(s.size()));
    s.initial_state(c.run.initial, y);
    // The run's budget, which the run lowers and restores between steps.
    const auto budget = std::make_shared<ThreadBudget>(c.solver.threads);
    IntegratorOptions options;
    options.threads = budget;
    const auto integrator = make_integrator(s, c.solver, y, 2e-5, options);
    int k = 0;
    for (double t = 1e-6; t <= 2e-5 + 1e-12; t += 1e-6) {
      if (alternate) budget->set_now(1 + (k++ % 3));  // 1, 2, 3, 1, ...
      integrator->advance(t, y);
    }
    finals.push_back(y);
  }
  CHECK(finals[1] == finals[0]);
}
