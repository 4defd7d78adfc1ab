// method = "multirate" (integrate/multirate_integrator.hpp): its table, a fast
// contact's sub-steps against a direct fine solution of the same node, and
// whole runs against single-rate dirk at a far tighter tolerance.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "stickslip/case/keys.hpp"
#include "stickslip/integrate/contact_substeps.hpp"
#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/integrate/multirate_integrator.hpp"
#include "stickslip/integrate/tolerances.hpp"
#include "stickslip/run/run.hpp"
#include "temp_dir.hpp"
#include "test_cases.hpp"

using namespace stickslip;

TEST_CASE("multirate's ESDIRK table: order 4, a third-order embedding, stiffly accurate",
          "[multirate]") {
  const EsdirkTable t = esdirk_table(4);
  REQUIRE(t.stages == 6);
  // Σ b c^k = 1/(k+1) for k < order; the embedding d for k < 3.
  for (int k = 0; k < 4; ++k) {
    double b = 0.0, d = 0.0;
    for (int i = 0; i < t.stages; ++i) {
      b += t.b[i] * std::pow(t.c[i], k);
      d += t.d[i] * std::pow(t.c[i], k);
    }
    CHECK(b == Approx(1.0 / (k + 1)).epsilon(1e-12));
    if (k < 3) CHECK(d == Approx(1.0 / (k + 1)).epsilon(1e-12));
  }
  for (int j = 0; j < t.stages; ++j) CHECK(t.at(t.stages - 1, j) == t.b[j]);
  CHECK(t.at(0, 0) == 0.0);
}

TEST_CASE("a fast contact's sub-steps converge to a direct solution of its node", "[multirate]") {
  // The node of contact 0 of the pair, slipping at ~5 v* and decelerating
  // under its friction, the rest of the lattice a given Φ(t). Reference: the
  // same four equations by classic RK4 with 2e5 steps of 1e-13 s (the law's
  // rate here is ~1e9 s⁻¹).
  const Case c = test::two_contact_case();
  const System system = test::make_system(c);
  const auto couplings = node_couplings(system);
  const NodeCoupling& coupling = couplings[0];
  const double v_star = system.contact_set().contacts()[0].v_star, H = 2e-8;
  Forcing forcing = Forcing::taylor(H, {2e5, -1e4}, {3e11, 1e11});
  const std::array<double, 4> x0{1e-7, -2e-8, 5 * v_star, 0.3 * v_star};

  // The reference carries ∫a_c dτ too (components 4, 5): the impulse the
  // sub-steps hand to the coarse level.
  using State = std::array<double, 6>;
  auto f = [&](double tau, const State& x) {
    const auto phi = forcing.at(tau);
    const auto a = system.contact_set().site_acceleration(0, {x[2], x[3]});
    return State{x[2],
                 x[3],
                 phi[0] + coupling.stiffness * x[0] + coupling.damping * x[2] + a[0],
                 phi[1] + coupling.stiffness * x[1] + coupling.damping * x[3] + a[1],
                 a[0],
                 a[1]};
  };
  State ref{x0[0], x0[1], x0[2], x0[3], 0.0, 0.0};
  const int n = 200000;
  const double h = H / n;
  for (int i = 0; i < n; ++i) {
    const double t = i * h;
    auto axpy = [](const State& x, double s, const State& k) {
      State out{};
      for (int j = 0; j < 6; ++j) out[j] = x[j] + s * k[j];
      return out;
    };
    const auto k1 = f(t, ref), k2 = f(t + h / 2, axpy(ref, h / 2, k1)),
               k3 = f(t + h / 2, axpy(ref, h / 2, k2)), k4 = f(t + h, axpy(ref, h, k3));
    for (int j = 0; j < 6; ++j) ref[j] += h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
  }
  REQUIRE(std::hypot(ref[2], ref[3]) < 0.9 * std::hypot(x0[2], x0[3]));  // it does change

  const EsdirkTable table = esdirk_table(4);
  std::vector<double> errors, impulse_errors;
  for (const double rtol : {1e-3, 1e-5, 1e-7}) {
    // The run's absolute tolerances at this rtol (integrate/tolerances.hpp).
    const ToleranceScales scale = tolerance_scales(system);
    const double atol_u = rtol * scale.displacement, atol_w = rtol * scale.velocity;
    const ContactSubsteps substeps(system, table, rtol, {atol_u, atol_u, atol_w, atol_w});
    const auto a0 = system.contact_set().site_acceleration(0, {x0[2], x0[3]});
    const SubstepResult r = substeps.advance(0, coupling, H, x0, a0, forcing, H / 16);
    const auto& end = r.points.back();
    CHECK(end.tau == H);
    const double error = std::max(std::abs(end.x[2] - ref[2]), std::abs(end.x[3] - ref[3])) /
                         std::hypot(ref[2], ref[3]);
    errors.push_back(error);
    impulse_errors.push_back(std::hypot(r.impulse[0] - ref[4], r.impulse[1] - ref[5]) /
                             std::hypot(ref[4], ref[5]));
  }
  INFO("relative velocity errors at rtol 1e-3, 1e-5, 1e-7: " << errors[0] << ", " << errors[1]
                                                             << ", " << errors[2]);
  // Within the tolerance asked for (the velocity's relative error, as the
  // error weights measure it).
  CHECK(errors[0] < 10 * 1e-3);
  CHECK(errors[1] < 10 * 1e-5);
  CHECK(errors[2] < 10 * 1e-7);
  INFO("impulse relative errors: " << impulse_errors[0] << ", " << impulse_errors[1] << ", "
                                   << impulse_errors[2]);
  CHECK(impulse_errors[0] < 10 * 1e-3);
  CHECK(impulse_errors[1] < 10 * 1e-5);
  CHECK(impulse_errors[2] < 10 * 1e-7);
}

namespace {

struct Events {
  std::vector<std::pair<double, int>> list;  // (time, +contact+1 slip / −(contact+1) stick)
  double impulse = 0.0;                      // ∫F_f dt at the end
  double residual = 0.0;                     // the energy audit's
  double work = 0.0;                         // the drive's
  SolverStats stats;
};

Events run(const System& system, Method method, double rtol, double t_end, long min_fast = 1,
           std::vector<int> watched = {0, 1}, long* most_fast = nullptr) {
  SolverParams p;
  p.method = method;
  p.rtol = rtol;
  p.multirate_min_fast = min_fast;
  IntegratorOptions options;
  options.watched_contacts = watched;
  if (most_fast)
    options.on_step = [most_fast](const StepRecord& r) {
      *most_fast = std::max(*most_fast, static_cast<long>(r.method_values[0]));  // fast_contacts
    };
  std::vector<double> y(static_cast<std::size_t>(system.size())), y0(y.size());
  system.initial_state(InitialState::rest, y0);
  y = y0;
  auto integrator = make_integrator(system, p, y, t_end, options);
  Events e;
  double t = 0.0;
  while (t < t_end) {
    t = integrator->advance(t_end, y);
    const auto roots = integrator->roots();
    for (std::size_t k = 0; k < roots.size(); ++k)
      if (roots[k] != 0) e.list.emplace_back(t, roots[k] * (watched[k] + 1));
  }
  e.impulse = y[system.quadrature_index(System::friction_impulse)];
  e.residual = system.energy_residual(t_end, y, y0);
  e.work = y[system.quadrature_index(System::work_in)];
  e.stats = integrator->stats();
  return e;
}

}  // namespace

TEST_CASE("multirate on the Fig. 10b pair: the slips of dirk at a far tighter tolerance",
          "[multirate]") {
  const Case c = test::two_contact_case();
  const System system = test::make_system(c);
  const double t_end = 1.2e-3;
  const Events reference = run(system, Method::dirk, 1e-10, t_end);
  REQUIRE(reference.list.size() >= 8);  // both contacts slip several times
  // The same slips whether the partition steps a slipping contact on its own
  // sub-steps (multirate_min_fast = 1; and 16: both contacts, three sites
  // apart, are lone and count 16, so one alone goes apart), or never (17:
  // every step single rate).
  for (const long min_fast : {1L, 16L, 17L}) {
    const Events mr = run(system, Method::multirate, 1e-7, t_end, min_fast);
    INFO("multirate_min_fast = " << min_fast);
    REQUIRE(mr.list.size() == reference.list.size());
    double worst = 0.0;
    for (std::size_t i = 0; i < mr.list.size(); ++i) {
      CHECK(mr.list[i].second == reference.list[i].second);
      worst = std::max(worst, std::abs(mr.list[i].first - reference.list[i].first));
    }
    INFO("largest slip/stick time difference " << worst << " s; fast contact-steps "
                                               << mr.stats.count("fast_contact_steps"));
    CHECK(worst < 2e-8);  // a slip lasts ~3 µs; its events move by < 1 % of that
    CHECK(mr.impulse == Approx(reference.impulse).epsilon(1e-6));
    CHECK(std::abs(mr.residual) < 100 * 1e-7);  // the audit's bound at this rtol
    // The audit's residual is the partition's work gap but for the coarse
    // steps' own error, which single rate shows (dirk's size at this rtol).
    const double unexplained = mr.residual * mr.work - mr.stats.amount("partition_work");
    INFO("residual x work " << mr.residual * mr.work << " J, partition_work "
                            << mr.stats.amount("partition_work") << " J");
    if (min_fast < 17) {
      CHECK(mr.stats.count("fast_contact_steps") > 0);  // slips were taken on sub-steps
      CHECK(mr.stats.count("substeps") > mr.stats.count("fast_contact_steps"));
      CHECK(std::abs(mr.stats.amount("partition_work")) > 10 * std::abs(unexplained));
    } else {
      CHECK(mr.stats.count("fast_contact_steps") == 0);  // two lone contacts count 16
      CHECK(mr.stats.count("substeps") == 0);
      CHECK(mr.stats.amount("partition_work") == 0.0);
    }
    CHECK(std::abs(unexplained) < 1e-7 * std::abs(mr.work));
  }
}

namespace {

// One row of steps.csv as multirate writes it.
struct StepRow {
  double t, h, error, h_lambda;
  long fast, substeps;
  double miss;
};

// A multirate run's steps.csv, and its header.
std::vector<StepRow> read_steps(const std::filesystem::path& file, std::string& header) {
  std::ifstream in(file);
  std::getline(in, header);
  std::vector<StepRow> rows;
  std::string line;
  while (std::getline(in, line)) {
    StepRow r{};
    REQUIRE(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%ld,%ld,%lf", &r.t, &r.h, &r.error,
                        &r.h_lambda, &r.fast, &r.substeps, &r.miss) == 7);
    rows.push_back(r);
  }
  return rows;
}

// The pair `c` (the Fig. 10b pair unless given) to t_end (the Fig. 10b pair
// through contact 0's first slip, ~0.7 ms), multirate with `min_fast`, and
// its steps.csv's header and rows.
std::vector<StepRow> pair_steps(long min_fast, const std::string& name, Summary& summary,
                                std::string& header, Case c = test::two_contact_case(),
                                double t_end = 9e-4) {
  c.run.t_end = t_end;
  c.run.average_from = 0.0;
  c.output.steps = true;
  c.solver.method = Method::multirate;
  c.solver.multirate_min_fast = min_fast;
  test::TempDir dir(name);
  RunOptions options{dir.path / "run", false, true};
  summary = run_case(c, options);
  return read_steps(options.out_dir / "steps.csv", header);
}

}  // namespace

TEST_CASE("multirate's steps.csv says how many contacts each step left to their sub-steps",
          "[multirate][steps]") {
  Summary summary;
  std::string header;
  // min_fast 1: the pair's slips on sub-steps.
  const auto rows = pair_steps(1, "stickslip_test_multirate_steps", summary, header);
  CHECK(header == "t,h,error,h_lambda,fast_contacts,substeps,miss");
  long fast_rows = 0, substeps = 0, fast_steps = 0;
  for (const StepRow& r : rows) {
    CHECK(r.fast >= 0);
    CHECK(r.fast <= 2);
    CHECK((r.fast == 0) == (r.substeps == 0));  // sub-steps exactly where a contact was fast
    fast_rows += r.fast > 0;
    fast_steps += r.fast;
    substeps += r.substeps;
  }
  CHECK(static_cast<long>(rows.size()) == summary.solver_stats.steps);
  CHECK(fast_rows > 0);
  CHECK(fast_steps == summary.solver_stats.count("fast_contact_steps"));
  CHECK(substeps <=
        summary.solver_stats.count("substeps"));  // the stats count retried attempts' too
}

TEST_CASE("steps.csv has multirate's columns where method = \"auto\" chose multirate",
          "[multirate][steps]") {
  // The recorders are laid out by the method the run integrates with, not
  // the case's "auto": the pair chooses multirate from multirate_min_fast 2.
  Case c = test::two_contact_case();
  c.run.t_end = 2e-5;
  c.run.average_from = 0.0;
  c.output.steps = true;
  c.solver.method = Method::automatic;
  c.solver.multirate_min_fast = 2;
  test::TempDir dir("stickslip_test_multirate_auto_steps");
  RunOptions options{dir.path / "run", false, true};
  const Summary summary = run_case(c, options);
  REQUIRE(summary.solver.at("method") == "multirate");
  std::ifstream in(options.out_dir / "steps.csv");
  std::string header, line;
  std::getline(in, header);
  CHECK(header == "t,h,error,h_lambda,fast_contacts,substeps,miss");
  long rows = 0;
  while (std::getline(in, line)) ++rows;
  CHECK(rows == summary.solver_stats.steps);
}

namespace {

// The Fig. 10b pair with three contacts in an L beside it, none of which is
// lone (two others around each), with v* far above the drive speed (they
// creep, never fast): two lone contacts of five, so a lone contact counts 8
// and no more.
Case pair_beside_triple() {
  Case c = test::two_contact_case();
  for (const auto [ix, iy] : {std::pair{1, 4}, std::pair{2, 4}, std::pair{1, 5}})
    c.interface.contacts.push_back({ix, iy, 1.0, 0});
  return c;
}

}  // namespace

TEST_CASE(
    "multirate steps contacts apart from multirate_min_fast of them, and after such a step down "
    "to an eighth as many",
    "[multirate][steps]") {
  // multirate_min_fast = 16 and the pair's two lone contacts counting 8
  // each (pair_beside_triple): a step leaves contacts to their sub-steps
  // only when both are fast, or when one is and the step before left any
  // (16 / kStayApart = 2). So no step has one contact apart right after a
  // single-rate step, and a slip's tail, with one still fast, stays apart.
  Summary summary;
  std::string header;
  const auto rows =
      pair_steps(16, "stickslip_test_multirate_stay_apart", summary, header, pair_beside_triple());
  long previous = 0, both = 0, one_after_apart = 0;
  for (const StepRow& r : rows) {
    INFO("t = " << r.t);
    if (r.fast == 1) {
      CHECK(previous > 0);  // only where the step before was apart
      ++one_after_apart;
    }
    both += r.fast >= 2;
    previous = r.fast;
  }
  CHECK(both > 0);
  CHECK(one_after_apart > 0);
}

TEST_CASE(
    "where most contacts are lone and they count multirate_min_fast, one lone slip goes apart by "
    "itself",
    "[multirate][steps]") {
  // The pair alone: both contacts lone, counting 16. From multirate_min_fast
  // 16 a single fast contact is stepped apart right after a single-rate step
  // (at 16 with the triple beside it, above, never); from 17 they do not
  // count enough, and every step is single rate.
  Summary summary;
  std::string header;
  long alone = 0, previous = 0;
  for (const StepRow& r : pair_steps(16, "stickslip_test_multirate_alone", summary, header)) {
    alone += r.fast == 1 && previous == 0;
    previous = r.fast;
  }
  CHECK(alone > 0);
  for (const StepRow& r : pair_steps(17, "stickslip_test_multirate_none", summary, header))
    CHECK(r.fast == 0);
  CHECK(summary.solver_stats.count("fast_contact_steps") == 0);
}

TEST_CASE("a multirate coarse step that would grow by less than half keeps its size",
          "[multirate][steps]") {
  // As ARKODE's fixed-step bounds [1, 1.5]: where the controller proposes a
  // growth g = 0.9 e^(-1/4) (the third-order embedding's error e of the step
  // just accepted) in [1, 1.5], the next step keeps H (and γ: the lattice is
  // not refactored), or is shorter after a failed attempt; never longer.
  Summary summary;
  std::string header;
  const auto rows = pair_steps(1, "stickslip_test_multirate_keep_step", summary, header);
  long kept = 0, grown = 0;
  for (std::size_t i = 1; i + 1 < rows.size(); ++i) {  // the last is cut to land on t_end
    const double g = 0.9 * std::pow(rows[i - 1].error, -0.25);
    const double ratio = rows[i].h / rows[i - 1].h;
    INFO("t = " << rows[i].t << ", H " << rows[i - 1].h << " then " << rows[i].h << ", g " << g);
    if (g > 1.0 + 1e-6 && g < 1.5 - 1e-6) {
      CHECK(ratio <= 1.0 + 1e-9);
      kept += std::abs(ratio - 1.0) <= 1e-9;
    }
    if (g > 1.5 + 1e-6 && g < 5.0) grown += std::abs(ratio - g) <= 1e-6 * g;
  }
  CHECK(kept > 50);
  CHECK(grown > 0);  // beyond 1.5 the step grows as proposed
}

TEST_CASE("multirate counts a lone fast contact eight times toward multirate_min_fast",
          "[multirate][steps]") {
  // The Fig. 10b pair's contacts, three sites apart, are lone. Beside the
  // triple (pair_beside_triple: 2 of 5 contacts lone) one slipping counts 8,
  // and at multirate_min_fast = 8 it is stepped apart, while the triple's
  // contacts count 1 each. So are the two moved side by side (one other
  // around each; at 5). Four contacts in a 2×2 square are not (three others
  // around each): they count 4, and at 5 every step is single rate although
  // all four slip (first at ~1.49 ms).
  Summary summary;
  std::string header;
  Case side_by_side = test::two_contact_case();
  side_by_side.interface.contacts[1].ix = 2;  // next to contact 0 at (1, 2)
  struct Lone {
    Case c;
    double t_end;
    long min_fast;
  };
  for (const Lone& l : {Lone{pair_beside_triple(), 9e-4, 8}, Lone{side_by_side, 1.1e-3, 5}}) {
    const auto lone =
        pair_steps(l.min_fast, "stickslip_test_multirate_lone", summary, header, l.c, l.t_end);
    long apart = 0;
    for (const StepRow& r : lone) apart += r.fast > 0;
    CHECK(apart > 0);
    CHECK(summary.solver_stats.count("fast_contact_steps") > 0);
  }

  Case square = test::two_contact_case();
  square.interface.contacts = {
      {1, 2, 4.75e-4, 0}, {2, 2, 2.09e-3, 0}, {1, 3, 4.75e-4, 0}, {2, 3, 2.09e-3, 0}};
  const auto rows =
      pair_steps(5, "stickslip_test_multirate_not_lone", summary, header, square, 1.6e-3);
  for (const StepRow& r : rows) CHECK(r.fast == 0);
  CHECK(summary.solver_stats.count("fast_contact_steps") == 0);
  REQUIRE(summary.events);
  REQUIRE(summary.events->per_contact.size() == 4);
  for (const auto& c : summary.events->per_contact) CHECK(c.slips > 0);  // all four slip
}

TEST_CASE("a fast contact's coarse node lands on its sub-steps once the coupling has settled",
          "[multirate][steps]") {
  // The Fig. 10b pair with each slip stepped apart (multirate_min_fast 1).
  // The coarse node of a fast contact ends where the coarse level and its
  // line take it; from the second coupling pass the line is set to land on
  // the sub-steps' end. A stuck contact takes a change of Φ between passes up
  // in its friction, so its end stays while its moments move: a line shifted
  // by the last miss alone counted that change twice, and the miss came back
  // with its sign flipped: median at acceptance 0.27 here, against 0.023.
  Summary summary;
  std::string header;
  const auto rows = pair_steps(1, "stickslip_test_multirate_lands", summary, header);
  std::vector<double> misses;
  for (const StepRow& r : rows) {
    CHECK(r.miss >= 0.0);
    CHECK(r.miss <= r.error);  // error is the larger of the coarse estimate and the miss
    if (r.fast > 0)
      misses.push_back(r.miss);
    else
      CHECK(r.miss == 0.0);
  }
  REQUIRE(misses.size() > 100);
  std::nth_element(misses.begin(), misses.begin() + misses.size() / 2, misses.end());
  CHECK(misses[misses.size() / 2] < 0.1);
}

namespace {

struct AttemptRow {
  double t, h;
  long fast, pass;
  double error, coupling, miss;
  std::string verdict, worst;
  long ix, iy, iz;
};

std::vector<AttemptRow> read_attempts(const std::filesystem::path& file, std::string& header) {
  std::ifstream in(file);
  std::getline(in, header);
  std::vector<AttemptRow> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream fields(line);
    for (std::string x; std::getline(fields, x, ',');) f.push_back(x);
    REQUIRE(f.size() == 12);
    rows.push_back({std::stod(f[0]), std::stod(f[1]), std::stol(f[2]), std::stol(f[3]),
                    std::stod(f[4]), std::stod(f[5]), std::stod(f[6]), f[7], f[8], std::stol(f[9]),
                    std::stol(f[10]), std::stol(f[11])});
  }
  return rows;
}

}  // namespace

TEST_CASE("attempts.csv accounts for every coarse attempt, and asking for it changes no step",
          "[multirate][steps]") {
  // The pair through contact 0's first slip, its slips on sub-steps
  // (multirate_min_fast 1): one row per attempt, whose accepted ones are
  // steps.csv's steps, each retry repeating its step at the same size and
  // each shrink at the same start with a shorter one.
  Case c = test::two_contact_case();
  c.run.t_end = 9e-4;
  c.run.average_from = 0.0;
  c.output.steps = true;
  c.solver.method = Method::multirate;
  c.solver.multirate_min_fast = 1;
  test::TempDir dir("stickslip_test_multirate_attempts");
  const RunOptions plain{dir.path / "plain", false, true};
  const Summary without = run_case(c, plain);
  c.output.attempts = true;
  const RunOptions options{dir.path / "attempts", false, true};
  const Summary summary = run_case(c, options);

  std::string header;
  const auto rows = read_attempts(options.out_dir / "attempts.csv", header);
  CHECK(header ==
        "t,h,fast_contacts,coupling_pass,error,coupling,miss,verdict,worst,worst_ix,worst_iy,"
        "worst_iz");
  CHECK(static_cast<long>(rows.size()) == summary.solver_stats.step_attempts);
  std::string steps_header;
  const std::vector<StepRow> steps = read_steps(options.out_dir / "steps.csv", steps_header);
  std::size_t accepted = 0;
  long shrinks = 0, retries = 0, apart = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const AttemptRow& r = rows[k];
    INFO("attempt " << k << " at t = " << r.t << ": " << r.verdict);
    CHECK(r.pass >= 1);
    CHECK(r.pass <= MultirateIntegrator::kCouplingIterations);
    CHECK((r.ix == -1) == (r.worst == "none" || r.worst == "work" || r.worst == "dissipated" ||
                           r.worst == "friction_impulse"));
    CHECK(r.ix < c.lattice.nx);
    CHECK(r.iy < c.lattice.ny);
    CHECK(r.iz < c.lattice.nz);
    apart += r.fast > 0;
    if (r.verdict == "accepted") {
      REQUIRE(accepted < steps.size());
      const StepRow& s = steps[accepted++];
      CHECK(s.h == Approx(r.h).epsilon(1e-9));
      CHECK(std::abs(s.t - (r.t + r.h)) <= 1e-11 * s.t);  // steps.csv's 12 digits
      CHECK(s.fast == r.fast);
      CHECK(r.error <= 1.0);
      continue;
    }
    REQUIRE(k + 1 < rows.size());  // the last attempt is accepted
    const AttemptRow& next = rows[k + 1];
    CHECK(next.t == r.t);
    if (r.verdict.rfind("retry", 0) == 0) {
      ++retries;
      CHECK(next.h == r.h);
      CHECK(next.fast > r.fast);  // the contact that failed joined the fast ones
    } else {
      ++shrinks;
      CHECK(next.h < r.h);
      if (r.verdict == "shrink_error") CHECK(r.error > 1.0);
    }
  }
  CHECK(accepted == steps.size());
  CHECK(shrinks == summary.solver_stats.error_test_failures);
  CHECK(apart > 0);
  CHECK(summary.solver_stats.step_attempts == static_cast<long>(accepted) + shrinks + retries);
  // Pay only for what is asked, and asking changes nothing: the same steps.
  std::ifstream a(plain.out_dir / "friction.csv"), b(options.out_dir / "friction.csv");
  const std::string ta((std::istreambuf_iterator<char>(a)), {}),
      tb((std::istreambuf_iterator<char>(b)), {});
  CHECK(ta == tb);
  CHECK(without.solver_stats.step_attempts == summary.solver_stats.step_attempts);
  CHECK(!std::filesystem::exists(plain.out_dir / "attempts.csv"));
}

TEST_CASE(
    "multirate on a 5x5 block of neighbouring contacts: each one's slips as dirk's at a "
    "far tighter tolerance (a known defect: fails today)",
    "[multirate][!shouldfail]") {
  // 25 contacts side by side: their slips spread through the block, and from
  // multirate_min_fast 16 more than 20 of them at once are stepped apart on
  // sub-steps, each reading its fast neighbours' motion off their sub-steps
  // (the coupling's fine terms), which the pair never exercises.
  //
  // It fails: dirk converges (the slip times at rtol 1e-7 and 1e-9 agree to
  // 3e-8 s), and the contacts that slip while the block is single rate (the
  // corners and edges first, 2.156 and 2.167 ms) agree with it to 1e-10 s,
  // but once the block goes apart the other 17 slip 0.55-0.86 µs early (a
  // slip lasts ~3.4 µs) at rtol 1e-7 and 1e-8 alike, and contact 14 slips
  // once more; with multirate_min_fast 1, 0.1-0.2 µs early. An error the
  // tolerance does not control: the partition's own, in a block of fast
  // neighbours. While it stands this test is expected to fail; when it
  // passes, drop [!shouldfail].
  Case c = test::two_contact_case();
  c.lattice = {10, 10, 3, 1e-4};
  c.interface.contacts.clear();
  for (int iy = 2; iy < 7; ++iy)
    for (int ix = 2; ix < 7; ++ix)
      c.interface.contacts.push_back({ix, iy, (ix + iy) % 2 ? 4.75e-4 : 6e-4, 0});
  const System system = test::make_system(c);
  std::vector<int> all(25);
  for (int k = 0; k < 25; ++k) all[static_cast<std::size_t>(k)] = k;
  const double t_end = 2.3e-3;  // through the first block slip, 2.16-2.19 ms
  const Events reference = run(system, Method::dirk, 1e-9, t_end, 1, all);
  long most_fast = 0;
  const Events mr = run(system, Method::multirate, 1e-7, t_end, 16, all, &most_fast);
  CHECK(most_fast > 20);
  // Per contact, its slips and sticks in order: within the block, contacts
  // slipping within nanoseconds of each other may swap places in the list.
  auto per_contact = [](const Events& e) {
    std::vector<std::vector<std::pair<double, int>>> out(25);
    for (const auto& [t, code] : e.list)
      out[static_cast<std::size_t>(std::abs(code) - 1)].emplace_back(t, code > 0 ? 1 : -1);
    return out;
  };
  const auto ref = per_contact(reference), got = per_contact(mr);
  long slips = 0;
  double worst = 0.0;
  for (std::size_t k = 0; k < 25; ++k) {
    INFO("contact " << k);
    REQUIRE(got[k].size() == ref[k].size());
    for (std::size_t i = 0; i < ref[k].size(); ++i) {
      CHECK(got[k][i].second == ref[k][i].second);
      worst = std::max(worst, std::abs(got[k][i].first - ref[k][i].first));
      slips += ref[k][i].second > 0;
    }
  }
  INFO("largest slip/stick time difference " << worst << " s over " << slips << " slips");
  CHECK(slips >= 25);  // every contact slips
  // dirk itself at rtol 1e-7 is 3e-8 s from its 1e-9: within 3 % of a slip.
  CHECK(worst < 1e-7);
  CHECK(std::abs(mr.residual) < 100 * 1e-7);
}

TEST_CASE("multirate_min_fast's help states the partition's own constants", "[multirate]") {
  // The reader (case/) does not reach the partition (integrate/), so the
  // help writes them out; this holds the two together.
  std::string help;
  for (const CaseKey& k : case_keys())
    if (k.section == "solver" && k.key == "multirate_min_fast") help = k.help;
  REQUIRE(!help.empty());
  CHECK(help.find("counting " + std::to_string(MultiratePartition::kLoneShare)) !=
        std::string::npos);
  CHECK(help.find("1/" + std::to_string(MultiratePartition::kStayApart) + " as many") !=
        std::string::npos);
  CHECK(help.find(MultiratePartition::kLoneNeighbours == 1
                      ? "at most one contact"
                      : "(no such wording)") != std::string::npos);
}
