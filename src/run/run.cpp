#include "stickslip/run/run.hpp"

#include <sundials/sundials_config.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>

#include "stickslip/model/contacts.hpp"
#include "stickslip/model/system.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/version.hpp"

namespace stickslip {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Progress on stderr, only when it is a terminal: simulated time, percent,
// steps, elapsed and estimated remaining wall time, twice a second at most.
class Progress {
 public:
  Progress(bool enabled, double t_end)
      : enabled_(enabled && isatty(STDERR_FILENO)), t_end_(t_end) {}
  void update(double t, long steps) {
    if (!enabled_) return;
    const double elapsed = seconds_since(start_);
    if (elapsed - last_ < 0.5) return;
    last_ = elapsed;
    const double fraction = t / t_end_;
    const double remaining = fraction > 0 ? elapsed * (1 - fraction) / fraction : 0.0;
    std::fprintf(stderr, "\r  t = %.4e s  %5.1f %%  %ld steps  %.1f s elapsed, ~%.1f s left   ", t,
                 100 * fraction, steps, elapsed, remaining);
    shown_ = true;
  }
  ~Progress() {
    if (shown_) std::fprintf(stderr, "\r%90s\r", "");
  }

 private:
  bool enabled_;
  double t_end_;
  Clock::time_point start_ = Clock::now();
  double last_ = 0.0;
  bool shown_ = false;
};

std::vector<int> traced_contacts(const OutputParams& out, std::size_t contacts) {
  std::vector<int> ids;
  if (out.traces == TraceSelection::all)
    for (std::size_t i = 0; i < contacts; ++i) ids.push_back(static_cast<int>(i));
  else if (out.traces == TraceSelection::list)
    ids = out.trace_ids;
  return ids;
}

nlohmann::json stats_json(const SolverStats& s) {
  return {{"steps", s.steps},
          {"step_attempts", s.step_attempts},
          {"rhs_explicit", s.rhs_explicit},
          {"rhs_implicit", s.rhs_implicit},
          {"newton_iterations", s.newton_iterations},
          {"newton_convergence_failures", s.newton_convergence_failures},
          {"linear_setups", s.linear_setups},
          {"jacobian_evaluations", s.jacobian_evaluations},
          {"error_test_failures", s.error_test_failures},
          {"last_step", s.last_step}};
}

}  // namespace

std::filesystem::path output_dir_for(const Case& c, const std::filesystem::path& out_flag) {
  if (!out_flag.empty()) return out_flag;
  if (!c.output.dir.empty()) return c.output.dir;
  return std::filesystem::path("out") / c.source.stem();
}

RunResult run_case(const Case& c, const RunOptions& options) {
  const auto wall_start = Clock::now();
  prepare_output_dir(options.out_dir, options.overwrite);
  const System system(c, place_contacts(c.lattice, c.interface));
  const auto& contacts = system.contacts();

  {
    std::ofstream out(options.out_dir / "contacts.csv");
    out << "id,ix,iy,v_star\n";
    char line[96];
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      std::snprintf(line, sizeof line, "%zu,%d,%d,%.17g\n", i, contacts[i].ix, contacts[i].iy,
                    contacts[i].v_star);
      out << line;
    }
  }
  CsvWriter friction(options.out_dir / "friction.csv", {"t", "F_f", "mu_inst"});
  const auto traced = traced_contacts(c.output, contacts.size());
  std::optional<CsvWriter> traces;
  if (!traced.empty()) {
    std::vector<std::string> header{"t"};
    for (int id : traced) {
      header.push_back("vx_" + std::to_string(id));
      header.push_back("vy_" + std::to_string(id));
    }
    traces.emplace(options.out_dir / "traces.csv", header);
  }

  std::vector<double> y0(static_cast<std::size_t>(system.size()));
  system.initial_state(c.run.initial, y0);
  std::vector<double> y = y0;
  ArkodeIntegrator integrator(system, c.solver, y0, c.run.t_end);

  const double normal_force = system.normal_force();
  std::vector<double> trace_row(2 * traced.size());
  auto record = [&](double t) {
    const double ff = system.friction_force(t, y);
    const double row[2] = {ff, ff / normal_force};
    friction.row(t, row);
    if (traces) {
      for (std::size_t k = 0; k < traced.size(); ++k) {
        const auto v = system.contact_velocity(static_cast<std::size_t>(traced[k]), y);
        trace_row[2 * k] = v[0];
        trace_row[2 * k + 1] = v[1];
      }
      traces->row(t, trace_row);
    }
  };

  record(0.0);
  Progress progress(!options.quiet, c.run.t_end);
  const double t_end = c.run.t_end, t_avg = c.run.average_from, dt = c.output.interval;
  const long outputs = static_cast<long>(std::ceil(t_end / dt - 1e-9));
  double impulse_at_avg = t_avg == 0.0 ? 0.0 : std::nan("");
  const std::int64_t impulse = system.quadrature_index(System::friction_impulse);
  for (long k = 1; k <= outputs; ++k) {
    const double t_out = std::min(t_end, static_cast<double>(k) * dt);
    if (std::isnan(impulse_at_avg) && t_avg <= t_out) {
      // μ averages from t_avg exactly: stop there (interpolated, like every output).
      integrator.advance_to(t_avg, y);
      impulse_at_avg = y[impulse];
    }
    integrator.advance_to(t_out, y);
    record(t_out);
    progress.update(t_out, integrator.stats().steps);
  }
  friction.flush();
  if (traces) traces->flush();

  RunResult result;
  result.contacts = contacts.size();
  result.theta = system.coverage();
  result.normal_force = normal_force;
  result.mu = (y[impulse] - impulse_at_avg) / ((t_end - t_avg) * normal_force);
  result.energy_residual = system.energy_residual(t_end, y, y0);
  result.stats = integrator.stats();
  result.wall_seconds = seconds_since(wall_start);

  nlohmann::json summary = {
      {"mu", result.mu},
      {"theta", result.theta},
      {"F_N", normal_force},
      {"contacts", result.contacts},
      {"t_end", t_end},
      {"average_from", t_avg},
      {"wall_seconds", result.wall_seconds},
      {"energy_residual", result.energy_residual},
      {"steady_sliding_mu", system.steady_sliding_mu()},
      {"method", integrator.method_name()},
      {"tolerances",
       {{"rtol", c.solver.rtol},
        {"atol_displacement", c.solver.atol_displacement},
        {"atol_velocity", c.solver.atol_velocity}}},
      {"solver_stats", stats_json(result.stats)},
      {"provenance", {{"git_commit", kGitCommit}, {"sundials_version", SUNDIALS_VERSION}}},
      {"case", to_json(c)},
  };
  write_json_atomically(options.out_dir / "summary.json", summary);
  return result;
}

}  // namespace stickslip
