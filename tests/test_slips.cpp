// slips.csv, the event catalogue (docs/USAGE.md, "slips.csv"): a row per slip of a
// watched contact, checked against the state at its two events as an
// integration of our own reaches them, its peak speed against the solution
// sampled densely inside the slip, and a slip under way at a checkpoint
// across the restart.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "stickslip/output/tables.hpp"
#include "stickslip/run/run.hpp"
#include "temp_dir.hpp"
#include "test_cases.hpp"

using namespace stickslip;
namespace fs = std::filesystem;

namespace {

// The Fig. 10b pair on 6×6×4 from rest through the first slip of each contact
// (contact 0 at ~0.854 ms, contact 1 at ~0.858 ms; each lasts ~3.4 µs).
Case first_slips() {
  Case c = test::two_contact_case();
  c.run.t_end = 8.7e-4;
  c.run.average_from = 0.0;  // no stop at t_avg: the run only advances to its output times
  c.output.format = OutputFormat::hdf5;  // every value a double
  return c;
}

struct Slip {
  double t_end;
  int contact;
  double t_start, duration, slip, peak_speed;
  double load_start, load_end, load_drop, F_f_start, F_f_end, F_f_drop;
};

std::vector<Slip> read_slips(const fs::path& dir) {
  std::map<std::string, std::vector<double>> c;
  for (auto& [name, values] : read_run_columns(dir, "slips")) c[name] = std::move(values);
  std::vector<Slip> slips(c.at("t_end").size());
  for (std::size_t i = 0; i < slips.size(); ++i)
    slips[i] = {c.at("t_end")[i],      static_cast<int>(c.at("contact")[i]),
                c.at("t_start")[i],    c.at("duration")[i],
                c.at("slip")[i],       c.at("peak_speed")[i],
                c.at("load_start")[i], c.at("load_end")[i],
                c.at("load_drop")[i],  c.at("F_f_start")[i],
                c.at("F_f_end")[i],    c.at("F_f_drop")[i]};
  return slips;
}

// What the catalogue should say about a contact at one of its events,
// computed from the state there by other means than the recorder's: the
// contact node's displacement read off the state, and the load on it as its
// acceleration (the whole right-hand side) less its own contact law's.
struct AtEvent {
  double t;
  int contact;
  EventKind kind;
  double speed, ux, uy, F_f, load;
};

AtEvent at_event(const System& s, double t, int contact, int root, std::span<const double> y) {
  const FrictionSite& site =
      s.contact_set().sites()[static_cast<std::size_t>(contact)];  // patch = 1
  std::vector<double> ydot(y.size());
  s.rhs(t, y, ydot);
  const auto wx = static_cast<std::size_t>(s.w_index(site.node, 0));
  const auto ux = static_cast<std::size_t>(s.u_index(site.node, 0));
  const auto a_c =
      s.contact_set().site_acceleration(static_cast<std::size_t>(contact), {y[wx], y[wx + 1]});
  return {t,
          contact,
          root > 0 ? EventKind::slip : EventKind::stick,
          std::hypot(y[wx], y[wx + 1]),
          y[ux],
          y[ux + 1],
          s.friction_force(t, y),
          s.mass() * std::hypot(ydot[wx] - a_c[0], ydot[wx + 1] - a_c[1])};
}

// The case integrated as its run integrates it (output interval t_end, no
// t_avg stop: advance(t_end) until it gets there), every event's state kept.
std::vector<AtEvent> integrate_to_events(const Case& c) {
  const System s = test::make_system(c);
  std::vector<double> y(static_cast<std::size_t>(s.size()));
  s.initial_state(c.run.initial, y);
  IntegratorOptions options;
  options.watched_contacts = {0, 1};
  const auto integrator = make_integrator(s, c.solver, y, c.run.t_end, options);
  std::vector<AtEvent> events;
  for (double t = 0.0; t < c.run.t_end;) {
    t = integrator->advance(c.run.t_end, y);
    const auto roots = integrator->roots();
    for (std::size_t k = 0; k < roots.size(); ++k)
      if (roots[k] != 0) events.push_back(at_event(s, t, static_cast<int>(k), roots[k], y));
  }
  return events;
}

using test::TempDir;

}  // namespace

TEST_CASE("slips: a row per slip, from its slip event to its stick, with the state's values there",
          "[slips]") {
  TempDir dir("stickslip_test_slips");
  for (Method m : {Method::dirk, Method::bdf, Method::imex, Method::multirate}) {
    Case c = first_slips();
    c.solver.method = m;
    c.solver.multirate_min_fast = 1;  // multirate: each slip on its own sub-steps
    // imex: its steps are held below ~2e-7 s by the lattice anyway; at the
    // default rtol its velocity tolerance takes them to ~5e-9 s in the creep.
    if (m == Method::imex) c.solver.rtol = 1e-3;
    c.output.interval = c.run.t_end;  // so the run's calls of advance are integrate_to_events'
    INFO(to_string(m));
    const fs::path out = dir.path / to_string(m);
    run_case(c, {out, false, true});
    const auto slips = read_slips(out);
    const auto events = integrate_to_events(c);

    // Each contact's slip events and the stick after each: one row each, in
    // the order the slips end.
    std::vector<std::pair<AtEvent, AtEvent>> expected;
    for (const AtEvent& e : events) {
      if (e.kind != EventKind::stick) continue;
      const auto start = std::find_if(events.rbegin(), events.rend(), [&](const AtEvent& s) {
        return s.contact == e.contact && s.t < e.t;
      });
      REQUIRE(start != events.rend());
      REQUIRE(start->kind == EventKind::slip);
      expected.emplace_back(*start, e);
    }
    REQUIRE(expected.size() == 2);  // the first slip of each contact
    REQUIRE(slips.size() == expected.size());
    for (std::size_t i = 0; i < slips.size(); ++i) {
      const Slip& r = slips[i];
      const auto& [start, end] = expected[i];
      INFO("slip " << i << " of contact " << r.contact);
      CHECK(r.contact == start.contact);
      CHECK(r.t_start == start.t);  // the events themselves, to the bit
      CHECK(r.t_end == end.t);
      CHECK(r.duration == end.t - start.t);
      // The contact's displacement between them, and the block's friction.
      CHECK(r.slip == std::hypot(end.ux - start.ux, end.uy - start.uy));
      CHECK(r.slip > 1e-7);  // a slip moves the contact ~0.2–0.3 µm
      CHECK(r.F_f_start == start.F_f);
      CHECK(r.F_f_end == end.F_f);
      CHECK(r.F_f_drop == start.F_f - end.F_f);
      // The load on the contact, from the whole right-hand side (rounding apart).
      CHECK(r.load_start == Approx(start.load).epsilon(1e-9));
      CHECK(r.load_end == Approx(end.load).epsilon(1e-9));
      CHECK(r.load_drop == r.load_start - r.load_end);
      // The slip relieves its contact: about half of the load goes (measured 55 % for
      // contact 0, 29 % for contact 1).
      CHECK(r.load_drop > 0.2 * r.load_start);
      // Never below the speeds at its ends, which are κ v* (to the root's tolerance).
      CHECK(r.peak_speed >= std::max(start.speed, end.speed));
      // ~0.16 and ~0.11 m/s: 340 and 51 times v* = 4.75e-4 and 2.09e-3 m/s.
      CHECK(r.peak_speed > 30 * start.speed);
    }
  }
}

TEST_CASE("slips: the peak speed is the slip's maximum, from samples of the solution", "[slips]") {
  // The peak is the largest speed at points of the computed solution: never
  // below a traced speed inside the slip (those are such points), never
  // above the solution's maximum, sampled here 1e-9 s apart inside each slip
  // by another integration with the same steps (output times do not change
  // them), and below it by what the solution curves between samples: the
  // nearer end of the step holding the maximum lies at most half that step
  // from it.
  TempDir dir("stickslip_test_slip_peaks");
  for (Method m : {Method::dirk, Method::multirate}) {  // SUNDIALS' root functions; sub-steps
    Case c = first_slips();
    c.solver.method = m;
    c.solver.multirate_min_fast = 1;  // multirate: each slip on its own sub-steps
    c.output.traces = ContactSelection::all;
    c.output.steps = true;  // (multirate: its coarse steps, which hold its sub-steps)
    INFO(to_string(m));
    const fs::path out = dir.path / to_string(m);
    run_case(c, {out, false, true});
    const auto slips = read_slips(out);
    REQUIRE(slips.size() == 2);
    const TraceTable traces = read_run_table(out, "traces");

    // The solution inside the slips, every 1e-9 s, and at the run's output times.
    std::vector<double> times;
    for (long k = 1; k <= std::lround(c.run.t_end / c.output.interval); ++k)
      times.push_back(std::min(c.run.t_end, static_cast<double>(k) * c.output.interval));
    for (const Slip& r : slips)
      for (double t = r.t_start; t < r.t_end; t += 1e-9) times.push_back(t);
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    const System s = test::make_system(c);
    std::vector<double> y(static_cast<std::size_t>(s.size()));
    s.initial_state(c.run.initial, y);
    IntegratorOptions options;
    options.watched_contacts = {0, 1};
    const auto integrator = make_integrator(s, c.solver, y, c.run.t_end, options);
    std::vector<double> dense_max(slips.size(), 0.0);
    std::vector<std::vector<std::pair<double, double>>> dense(slips.size());  // (t, speed)
    for (double target : times)
      for (double t = -1.0; t < target;) {
        t = integrator->advance(target, y);
        for (std::size_t i = 0; i < slips.size(); ++i)
          if (t >= slips[i].t_start && t <= slips[i].t_end) {
            const double speed =
                s.contact_set().contact_speed(static_cast<std::size_t>(slips[i].contact), y);
            dense_max[i] = std::max(dense_max[i], speed);
            dense[i].emplace_back(t, speed);
          }
      }
    std::map<std::string, std::vector<double>> steps;
    for (auto& [name, values] : read_run_columns(out, "steps")) steps[name] = std::move(values);
    const auto& step_end = steps.at("t");
    const auto& step_size = steps.at("h");

    for (std::size_t i = 0; i < slips.size(); ++i) {
      const Slip& r = slips[i];
      INFO("contact " << r.contact << ": peak " << r.peak_speed << ", dense maximum "
                      << dense_max[i]);
      auto column = [&](const std::string& name) -> const std::vector<double>& {
        const auto at = std::find(traces.columns.begin(), traces.columns.end(), name);
        REQUIRE(at != traces.columns.end());
        return traces.values[static_cast<std::size_t>(at - traces.columns.begin())];
      };
      const auto& vx = column("vx_" + std::to_string(r.contact));
      const auto& vy = column("vy_" + std::to_string(r.contact));
      int inside = 0;
      for (std::size_t k = 0; k < traces.t.size(); ++k)
        if (traces.t[k] >= r.t_start && traces.t[k] <= r.t_end) {
          CHECK(r.peak_speed >= std::hypot(vx[k], vy[k]));
          ++inside;
        }
      CHECK(inside >= 3);  // a 3.4 µs slip, traced every 1 µs
      // The solution's maximum lies within ~2e-8 m/s (1e-7 of it) of the
      // densest samples' (curvature ~1e11 m/s³, half a spacing 5e-10 s).
      CHECK(r.peak_speed <= dense_max[i] * (1 + 1e-6));
      // Below it by at most |v''| (h/2)² / 2 for the step h holding the
      // maximum, with v'' the largest second difference of the samples (1e-8 s
      // apart) over that step. Measured: 4e-4-1e-3 of it at the default rtol
      // 1e-6, steps of a few 1e-8 s near the top.
      const auto& samples = dense[i];
      const auto top = std::max_element(samples.begin(), samples.end(),
                                        [](auto a, auto b) { return a.second < b.second; });
      const auto holding = std::lower_bound(step_end.begin(), step_end.end(), top->first);
      REQUIRE(holding != step_end.end());
      const double h = step_size[static_cast<std::size_t>(holding - step_end.begin())];
      constexpr std::ptrdiff_t kApart = 10;  // samples, 1e-8 s
      double curvature = 0.0;
      for (std::ptrdiff_t k = kApart; k + kApart < std::ssize(samples); ++k) {
        const auto [t, v] = samples[static_cast<std::size_t>(k)];
        if (t < *holding - h || t > *holding) continue;
        const auto& before = samples[static_cast<std::size_t>(k - kApart)];
        const auto& after = samples[static_cast<std::size_t>(k + kApart)];
        const double dt = 0.5 * (after.first - before.first);
        curvature = std::max(curvature, std::abs(after.second - 2 * v + before.second) / (dt * dt));
      }
      REQUIRE(curvature > 0.0);
      INFO("step " << h << " s at the top, |v''| " << curvature << " m/s^3");
      CHECK(r.peak_speed >= dense_max[i] - 0.5 * curvature * (0.5 * h) * (0.5 * h));
    }
  }
}

TEST_CASE("slips: a slip under way at a checkpoint is written whole after the restart",
          "[slips][restart]") {
  TempDir dir("stickslip_test_slips_restart");
  Case c = first_slips();
  run_case(c, {dir.path / "whole", false, true});
  const auto whole = read_slips(dir.path / "whole");
  REQUIRE(whole.size() == 2);
  // A checkpoint at an output time inside contact 0's slip (3.4 µs, outputs every 1 µs).
  const long k = std::lround(std::ceil(whole[0].t_start / c.output.interval));
  const double t_checkpoint = static_cast<double>(k) * c.output.interval;
  REQUIRE(whole[0].contact == 0);
  REQUIRE(t_checkpoint > whole[0].t_start);
  REQUIRE(t_checkpoint < whole[0].t_end);

  c.run.checkpoint_every = t_checkpoint;
  {  // killed right after that checkpoint: no summary, the checkpoint there
    CaseRun killed(c, {dir.path / "restarted", false, true});
    while (killed.next_output() <= k) killed.output();
  }
  REQUIRE(fs::exists(dir.path / "restarted" / "checkpoint.bin"));
  run_case(c, {dir.path / "restarted", false, true, true});
  const auto restarted = read_slips(dir.path / "restarted");
  REQUIRE(restarted.size() == whole.size());
  const Slip &a = whole[0], &b = restarted[0];
  // Its start is the first attempt's, to the bit: it came through the checkpoint.
  CHECK(b.t_start == a.t_start);
  CHECK(b.load_start == a.load_start);
  CHECK(b.F_f_start == a.F_f_start);
  // The rest comes from a new integrator from the checkpoint on: close.
  CHECK(std::abs(b.t_end - a.t_end) < 1e-8);
  CHECK(b.slip == Approx(a.slip).epsilon(1e-3));
  CHECK(b.peak_speed == Approx(a.peak_speed).epsilon(1e-3));
  CHECK(b.load_end == Approx(a.load_end).epsilon(1e-3));
  CHECK(restarted[1].t_start == Approx(whole[1].t_start).epsilon(1e-6));

  // A run begun by code older than slips.csv (no table, a checkpoint without
  // the slip under way) continues: its catalogue starts at the restart.
  c.output.format = OutputFormat::csv;
  {
    CaseRun killed(c, {dir.path / "older", false, true});
    while (killed.next_output() <= k) killed.output();
  }
  fs::remove(dir.path / "older" / "slips.csv");
  Checkpoint older = read_checkpoint(dir.path / "older");
  older.recorders = nlohmann::json::object();
  write_checkpoint(dir.path / "older", older);
  run_case(c, {dir.path / "older", false, true, true});
  const auto continued = read_slips(dir.path / "older");
  REQUIRE(continued.size() == 1);  // contact 0's slip began before the restart
  CHECK(continued[0].contact == 1);
  CHECK(continued[0].t_start == Approx(whole[1].t_start).epsilon(1e-6));
}
