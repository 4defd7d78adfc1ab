// One window of a run, continued from a checkpoint with any method and rtol:
// the verification and the benchmark of a block slip (docs/notes/performance-history.md,
// "Multirate"). Prints JSON: the wall time, the solver statistics, and per
// contact the first slip's time, the number of slips and the peak speed in
// the window, and the friction force at its end.
//
//   stickslip_block_slip CASE CHECKPOINT_DIR DURATION METHOD RTOL [SAMPLE] [section.key=value ...]
//   stickslip_block_slip --prepare CASE CHECKPOINT_DIR T0 [section.key=value ...]
//
// --prepare integrates the case from rest to T0 with its own method and
// writes the checkpoint the windows start from.
//
// SAMPLE (default 1e-8 s) is the interval at which speeds are sampled for
// their peaks; events come from the integrator's root finding.

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stickslip/case/placement.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/output/checkpoint.hpp"

using namespace stickslip;

int prepare(int argc, char** argv) {
  std::vector<std::string> sets(argv + 5, argv + argc);
  sets.push_back("solver.threads=1");
  const Case c = read_case(argv[2], sets);
  const System system(c, place_contacts(c.lattice, c.interface));
  const double t0 = std::stod(argv[4]);
  std::vector<double> y(static_cast<std::size_t>(system.size()));
  system.initial_state(c.run.initial, y);
  auto integrator = make_integrator(system, c.solver, y, t0, {});
  integrator->advance(t0, y);
  Checkpoint ck;
  ck.t = t0;
  ck.state = y;
  ck.stats = integrator->stats();
  std::filesystem::create_directories(argv[3]);
  write_checkpoint(argv[3], ck);
  std::cout << "checkpoint at t = " << t0 << " s in " << argv[3] << "\n";
  return 0;
}

int main(int argc, char** argv) {
  if (argc >= 5 && std::string(argv[1]) == "--prepare") return prepare(argc, argv);
  if (argc < 6) {
    std::cerr << "usage: " << argv[0]
              << " CASE CHECKPOINT_DIR DURATION METHOD RTOL [SAMPLE] [section.key=value ...]\n";
    return 2;
  }
  std::vector<std::string> sets;
  double sample = 1e-8;
  for (int i = 6; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.find('=') == std::string::npos)
      sample = std::stod(a);
    else
      sets.push_back(a);
  }
  sets.push_back(std::string("solver.method=\"") + argv[4] + "\"");
  sets.push_back(std::string("solver.rtol=") + argv[5]);
  sets.push_back("solver.threads=1");
  const Case c = read_case(argv[1], sets);
  const System system(c, place_contacts(c.lattice, c.interface));
  const Checkpoint ck = read_checkpoint(argv[2]);
  const double t0 = ck.t, t1 = t0 + std::stod(argv[3]);
  const std::size_t nc = system.contact_set().contacts().size();

  IntegratorOptions options;
  for (std::size_t i = 0; i < nc; ++i) options.watched_contacts.push_back(static_cast<int>(i));
  std::vector<double> y = ck.state;
  const auto start = std::chrono::steady_clock::now();
  auto integrator = make_integrator(system, c.solver, y, t1, options, t0);
  std::vector<double> first_slip(nc, NAN), peak(nc, 0.0);
  std::vector<int> slips(nc, 0);
  auto sample_speeds = [&](const std::vector<double>& state) {
    for (std::size_t i = 0; i < nc; ++i) {
      const auto s = system.contact_set().contact_velocity(i, state);
      peak[i] = std::max(peak[i], std::hypot(s[0], s[1]));
    }
  };
  // TRACE_CONTACT=i: contact i's velocity at every sample, in the JSON.
  const long trace_contact =
      std::getenv("TRACE_CONTACT") ? std::atol(std::getenv("TRACE_CONTACT")) : -1;
  std::vector<std::array<double, 3>> trace;
  double t = t0;
  long k = 1;
  while (t < t1) {
    const double t_out = std::min(t1, t0 + static_cast<double>(k) * sample);
    t = integrator->advance(t_out, y);
    sample_speeds(y);
    if (trace_contact >= 0) {
      const auto v =
          system.contact_set().contact_velocity(static_cast<std::size_t>(trace_contact), y);
      trace.push_back({t, v[0], v[1]});
    }
    const auto roots = integrator->roots();
    for (std::size_t i = 0; i < nc; ++i)
      if (roots[i] > 0) {
        if (slips[i] == 0) first_slip[i] = t;
        ++slips[i];
      }
    if (t >= t_out) ++k;
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  nlohmann::json out;
  out["method"] = argv[4];
  out["rtol"] = std::stod(argv[5]);
  out["t0"] = t0;
  out["t1"] = t1;
  out["wall"] = wall;
  out["stats"] = integrator->stats();
  out["friction_force_end"] = system.friction_force(t1, y);
  out["energy_residual"] = system.energy_residual(t1, y, ck.state);
  out["first_slip"] = first_slip;
  out["slips"] = slips;
  out["peak_speed"] = peak;
  std::vector<double> end_speed(nc);
  for (std::size_t i = 0; i < nc; ++i) {
    const auto v = system.contact_set().contact_velocity(i, y);
    end_speed[i] = std::hypot(v[0], v[1]);
  }
  out["end_speed"] = end_speed;
  if (trace_contact >= 0) out["trace"] = trace;
  std::cout << out.dump() << "\n";
  return 0;
}
