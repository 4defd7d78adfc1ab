#include "stickslip/integrate/make_integrator.hpp"

#include <stdexcept>
#include <string>
#include <utility>

#include "stickslip/integrate/arkstep_integrator.hpp"
#include "stickslip/integrate/cvode_integrator.hpp"
#include "stickslip/integrate/multirate_integrator.hpp"
#include "stickslip/integrate/tolerances.hpp"

namespace stickslip {

MethodChoice choose_method(const System& system, const SolverParams& solver) {
  if (solver.method != Method::automatic) return {solver.method, "given"};
  if (solver.step > 0)
    return {Method::imex,
            "method = \"auto\" with a fixed step: imex, the cheapest fixed-step "
            "method (docs/PERFORMANCE.md)"};
  std::size_t weak = 0;  // contacts that stick-slip at the drive speed: their law's
  for (std::size_t i = 0; i < system.contact_set().contacts().size();
       ++i)  // speed scale is below it
    if (system.contact_set().speed_scale(i) < system.drive_velocity()) ++weak;
  // bdf rather than dirk: on the 30 points of Fig. 7 at v = 3e-4 both agree
  // to 2.4e-6 in μ, bdf took 1-7 s on each, dirk up to 54 s and stalled on
  // one (its contacts' Newton failing again and again in the creep).
  if (weak == 0)
    return {Method::bdf,
            "method = \"auto\": bdf, since no contact has v* below the drive "
            "speed (steady sliding or creep, where its steps grow; "
            "docs/PERFORMANCE.md)"};
  // multirate where there are contacts enough for it to step them apart
  // (multirate_min_fast; in a block slip those with v* above the drive speed
  // slip too): fewer slipping together, its steps are single rate
  // and cost what dirk's do (15x15x10, theta 0.04: 39.7 against 40.6 s),
  // more, a block slip costs 2.9x less (30x30x10: 176 against 514 s) and a
  // whole 15x15 point at theta 0.498 the same (207 against 206 s;
  // docs/notes/performance-history.md, "Multirate"). Beyond the dense LU's reach too,
  // where both go matrix free: on 60x60x10 at coverage 0.498 the first 40 us
  // of a block slip cost dirk 6.1x multirate's CPU (875 against 143 s). Not
  // with patches, which it does not step. Contacts are counted one each, not
  // a lone one as the partition does: on 15x15x10 at theta 0.04 (9 lone
  // contacts) multirate, each lone slip apart, took 1.3x less time than dirk
  // at rtol 1e-5 but was 68x further from a converged run in mu, and at
  // equal accuracy was no faster (docs/notes/performance-history.md, "Multirate").
  const std::size_t contacts = system.contact_set().contacts().size();
  if (system.contact_set().patch() == 1 &&
      contacts >= static_cast<std::size_t>(solver.multirate_min_fast))
    return {Method::multirate,
            "method = \"auto\": multirate, since " + std::to_string(weak) + " of " +
                std::to_string(contacts) +
                " contacts have v* below the drive speed and stick-slip, and there are at least "
                "[solver] multirate_min_fast = " +
                std::to_string(solver.multirate_min_fast) +
                " to slip together: a block slip on their own sub-steps costs a fraction of "
                "dirk's global steps (docs/PERFORMANCE.md)"};
  return {Method::dirk, "method = \"auto\": dirk, since " + std::to_string(weak) + " of " +
                            std::to_string(contacts) +
                            " contacts have v* below the drive speed and stick-slip, where dirk "
                            "is the fastest at equal accuracy (docs/PERFORMANCE.md)"};
}

ResolvedSolver resolve_solver(const System& system, const SolverParams& given) {
  ResolvedSolver solver{given, with_absolute_tolerances(system, given), {}};
  MethodChoice choice = choose_method(system, given);
  solver.params.method = choice.method;
  solver.params.threads = resolved_threads(given, system.num_nodes());
  if (given.method == Method::automatic) solver.chosen_by = std::move(choice.reason);
  solver.audit_bound = given.audit_bound > 0 ? given.audit_bound
                       : given.step > 0      ? kFixedStepAuditBound
                                             : 100 * given.rtol;
  return solver;
}

std::unique_ptr<Integrator> make_integrator(const System& system, const SolverParams& solver,
                                            std::span<const double> y0, double t_stop,
                                            IntegratorOptions options, double t0) {
  return make_integrator(system, resolve_solver(system, solver), y0, t_stop, std::move(options),
                         t0);
}

std::unique_ptr<Integrator> make_integrator(const System& system, const ResolvedSolver& solver,
                                            std::span<const double> y0, double t_stop,
                                            IntegratorOptions options, double t0) {
  const SolverParams& chosen = solver.params;
  if (!options.threads) options.threads = std::make_shared<const ThreadBudget>(chosen.threads);
  switch (method_info(chosen.method).package) {
    case Package::arkstep:
      return std::make_unique<ArkStepIntegrator>(system, chosen, y0, t0, t_stop,
                                                 std::move(options));
    case Package::cvode:
      return std::make_unique<CvodeIntegrator>(system, chosen, y0, t0, t_stop, std::move(options));
    case Package::own:
      return std::make_unique<MultirateIntegrator>(system, chosen, y0, t0, t_stop,
                                                   std::move(options));
  }
  throw std::logic_error("make_integrator: no adapter for the method's package");
}

nlohmann::json describe_solver(const System& system, const ResolvedSolver& solver,
                               const Integrator& integrator) {
  const SolverParams& p = solver.params;
  nlohmann::json d = integrator.description();
  if (method_info(p.method).whole_implicit)
    d["linear_solver"] = to_string(linear_solver_info(p.linear_solver).solver);
  if (p.step > 0) {
    d["fixed_step"] = p.step;
  } else {
    d["adaptive"] = true;
    d.update(describe_tolerances(system, solver.given, p));
  }
  if (!solver.chosen_by.empty()) d["chosen_by"] = solver.chosen_by;
  d["threads"] = p.threads;
  return d;
}

std::span<const StepColumn> step_columns(Method m) {
  if (m == Method::multirate) return MultirateIntegrator::kStepColumns;
  return {};
}

}  // namespace stickslip
