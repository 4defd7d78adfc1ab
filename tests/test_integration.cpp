// Integrated runs checked against exact results: the exact stage solve, the
// energy audit's convergence with tolerance, steady sliding's exact μ, and how a
// SUNDIALS failure is reported.
#include <fcntl.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "stickslip/case/reader.hpp"
#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/run/run.hpp"
#include "temp_dir.hpp"
#include "test_cases.hpp"

using namespace stickslip;

using stickslip::test::make_system;
using stickslip::test::two_contact_case;

TEST_CASE("implicit stage equation is solved to rounding, from rest to fast slip", "[stage]") {
  const Case c = two_contact_case();
  const System s = make_system(c);
  std::mt19937_64 gen(11);
  std::uniform_real_distribution<double> angle(0.0, 2 * std::numbers::pi);
  std::vector<double> b(static_cast<std::size_t>(s.size())), z(b.size()), f(b.size());
  for (double gamma : {1e-12, 1e-10, 1e-8, 1e-6})
    for (double speed : {1e-16, 1e-9, 1e-6, 4e-4, 3e-3, 0.2}) {
      for (auto& x : b) x = speed * std::cos(angle(gen));
      const std::vector<double> at_rest(b.size(), 0.0);  // a poor predictor
      z = b;
      s.contact_set().solve_implicit_stage(gamma, at_rest, z);
      s.rhs_implicit(0.0, z, f);
      double worst = 0.0;
      for (std::size_t i = 0; i < b.size(); ++i)
        worst = std::max(worst, std::abs(z[i] - gamma * f[i] - b[i]));
      INFO("gamma = " << gamma << ", |b| ~ " << speed);
      CHECK(worst <= 1e-13 * speed);
    }
}

TEST_CASE("implicit stage equation: the root next to the predictor, found from it", "[stage]") {
  // Site 0 moving along x: its stage equation s − γ a_c(s) = b reads
  // h(λ) = λ − γ a_x(λ) = |b| for the speed λ, with a_x from rhs_implicit. On
  // the weakening branch h falls where γ ε f0 |φ'|/(m v*) > 1 + γ η_c, so at
  // γ = 1e-6 s a |b| between h's local maximum and minimum has three roots.
  const Case c = two_contact_case();
  const System s = make_system(c);
  const std::int64_t wx = s.w_index(s.contact_set().sites()[0].node, 0);
  const double v_star = s.contact_set().sites()[0].v_star, gamma = 1e-6;
  std::vector<double> y(static_cast<std::size_t>(s.size())), f(y.size());
  auto h = [&](double lambda) {
    y[wx] = lambda;
    s.rhs_implicit(0.0, y, f);
    return lambda - gamma * f[wx];
  };
  // h's local maximum and minimum, on a grid in ln λ over (v*, 1e4 v*).
  std::vector<double> grid, values;
  for (double lambda = v_star; lambda < 1e4 * v_star; lambda *= 1.01) {
    grid.push_back(lambda);
    values.push_back(h(lambda));
  }
  std::size_t top = 0;
  while (top + 1 < grid.size() && values[top + 1] >= values[top]) ++top;
  std::size_t bottom = top;
  while (bottom + 1 < grid.size() && values[bottom + 1] <= values[bottom]) ++bottom;
  REQUIRE(top > 0);
  REQUIRE(bottom > top);
  REQUIRE(bottom + 1 < grid.size());
  const double b_len = 0.5 * (values[top] + values[bottom]);

  auto solve = [&](double predictor_speed) {
    return s.contact_set().site_stage(0, gamma, {b_len, 0.0}, predictor_speed, false);
  };
  // The low root lies below h's maximum, the high one above its minimum.
  const ContactStage low = solve(0.9 * grid[top]), high = solve(1.1 * grid[bottom]);
  CHECK(low.s[0] < grid[top]);
  CHECK(high.s[0] > grid[bottom]);
  for (const ContactStage& root : {low, high}) {
    CHECK(std::abs(h(root.s[0]) - b_len) <= 1e-13 * b_len);
    CHECK(root.s[1] == 0.0);
  }
  // From a predictor at a root, Newton confirms it at once.
  CHECK(solve(low.s[0]).iterations <= 2);
  CHECK(solve(high.s[0]).iterations <= 2);
}

TEST_CASE("energy audit residual shrinks as the tolerance is tightened", "[audit]") {
  // From rest through the first slips of the weak contact: the audit must
  // close better when the integration is more accurate.
  Case c = two_contact_case();
  const System s = make_system(c);
  auto residual = [&](double rtol) {
    c.solver.rtol = rtol;
    c.solver.atol_displacement = rtol * 1e-6;
    c.solver.atol_velocity = rtol * 1e-1;
    std::vector<double> y0(static_cast<std::size_t>(s.size()));
    s.initial_state(InitialState::rest, y0);
    std::vector<double> y = y0;
    const double t_end = 1e-3;
    const auto integrator = make_integrator(s, c.solver, y0, t_end, {});
    integrator->advance(t_end, y);
    return std::abs(s.energy_residual(t_end, y, y0));
  };
  const double loose = residual(1e-4), tight = residual(1e-7);
  INFO("residual at rtol 1e-4: " << loose << ", at rtol 1e-7: " << tight);
  CHECK(tight < loose / 10);
  CHECK(tight < 1e-6);
}

TEST_CASE("cases/steady.toml reaches the exact steady-sliding mu", "[steady]") {
  const Case c = read_case(std::filesystem::path(STICKSLIP_SOURCE_DIR) / "cases/steady.toml");
  const auto contacts = place_contacts(c.lattice, c.interface);
  // Every contact must be in the steady regime v* ≥ 3v for §7's formula.
  for (const auto& ct : contacts) REQUIRE(ct.v_star >= 3 * c.drive.velocity);

  const double exact = stickslip::test::steady_sliding_mu_exact(c, contacts);

  RunOptions options;
  const ::test::TempDir tmp("stickslip_test_steady");
  options.out_dir = tmp.path / "out";
  options.overwrite = true;
  options.quiet = true;
  const Summary r = run_case(c, options);
  const auto summary = nlohmann::json::parse(std::ifstream(options.out_dir / "summary.json"));
  INFO("mu = " << r.mu << ", exact " << exact);
  CHECK(std::abs(r.mu / exact - 1) < 5e-3);
  // Steady: no block slip, so no whole cycles, and F_f's error bar (from its
  // autocorrelation) far inside the distance to the exact value allowed.
  CHECK(summary.at("mu_whole_cycles").is_null());
  CHECK(summary.at("regime").at("kind") == "steady sliding");
  CHECK(summary.at("mu_error_from") == "autocorrelation");
  CHECK(r.mu_error < 1e-4 * exact);
  CHECK(std::abs(r.energy_residual) < 1e-5);
}

TEST_CASE("driven output by output, a run keeps its energy balance at every output time",
          "[integration]") {
  // run_case audits energy at t_end only; its phases let the audit be taken
  // at every output time (MODEL.md §8), through the slips of the pair.
  const test::TempDir tmp("stickslip_test_case_run_phases");
  Case c = two_contact_case();
  c.run.t_end = 1.2e-3;
  c.run.average_from = 2e-4;
  c.output.interval = 2e-5;
  RunOptions options{.out_dir = tmp.path / "run", .quiet = true};
  CaseRun run(c, options);
  REQUIRE(run.outputs() == 60);
  std::vector<double> y0(static_cast<std::size_t>(run.system().size()));
  run.system().initial_state(c.run.initial, y0);
  double worst = 0.0;
  while (run.next_output() <= run.outputs()) {
    const double t = static_cast<double>(run.next_output()) * c.output.interval;
    run.output();
    // Below ~2e-4 s the work done is tiny and the relative residual is noise.
    if (t >= c.run.average_from)
      worst = std::max(worst, std::abs(run.system().energy_residual(t, run.state(), y0)));
  }
  INFO("largest |relative residual| along the run: " << worst);
  CHECK(worst < 10 * c.solver.rtol);
  CHECK_THROWS_AS(run.output(), std::logic_error);  // past the last output time
  const Summary s = run.finish();
  CHECK(std::abs(s.energy_residual) <= worst);  // t_end is one of the times checked
}

namespace {

// What `f` writes to stderr (file descriptor 2), and the message of the
// IntegrationError it throws ("" if none).
struct Outcome {
  std::string error, printed;
};
template <class F>
Outcome capture_failure(F&& f) {
  const stickslip::test::TempDir dir;
  const auto path = dir.path / "stderr.txt";
  std::fflush(stderr);
  const int saved = ::dup(2);
  const int file = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  ::dup2(file, 2);
  ::close(file);
  Outcome out;
  try {
    f();
  } catch (const IntegrationError& e) {
    out.error = e.what();
  }
  std::fflush(stderr);
  ::dup2(saved, 2);
  ::close(saved);
  std::ifstream in(path);
  out.printed.assign(std::istreambuf_iterator<char>(in), {});
  return out;
}

}  // namespace

TEST_CASE("a SUNDIALS failure names its flag and carries SUNDIALS' message, printing nothing",
          "[errors]") {
  const Case c = two_contact_case();
  const System s = make_system(c);
  std::vector<double> y(static_cast<std::size_t>(s.size()));
  s.initial_state(InitialState::rest, y);
  SECTION("a tolerance ARKStep refuses") {
    SolverParams p = c.solver;
    p.method = Method::dirk;
    p.rtol = -1e-6;
    const Outcome o = capture_failure([&] { make_integrator(s, p, y, 1e-3, {}); });
    CHECK_THAT(o.error, Catch::Contains("ARKStepSVtolerances failed: ARK_ILL_INPUT") &&
                            Catch::Contains("reltol < 0 illegal."));
    CHECK(o.printed.empty());
  }
  SECTION("a tolerance CVODE refuses") {
    SolverParams p = c.solver;
    p.method = Method::bdf;
    p.rtol = -1e-6;
    const Outcome o = capture_failure([&] { make_integrator(s, p, y, 1e-3, {}); });
    CHECK_THAT(o.error, Catch::Contains("CVodeSVtolerances failed: CV_ILL_INPUT") &&
                            Catch::Contains("reltol < 0 illegal."));
    CHECK(o.printed.empty());
  }
  SECTION("a step ARKStepEvolve refuses to take") {
    SolverParams p = c.solver;
    p.method = Method::imex;
    // One rounding unit after t0: too close to start.
    const double t0 = 1.0, t_stop = std::nextafter(t0, 2.0);
    const Outcome o =
        capture_failure([&] { make_integrator(s, p, y, t_stop, {}, t0)->advance(t_stop, y); });
    CHECK_THAT(o.error, Catch::Contains("ARKStepEvolve failed at t = 1 s: ARK_TOO_CLOSE") &&
                            Catch::Contains("tout too close to t0 to start integration."));
    CHECK(o.printed.empty());
  }
}
