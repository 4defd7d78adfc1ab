#include "stickslip/case/case.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "stickslip/case/methods.hpp"

namespace stickslip {

const char* to_string(GradDiv g) {
  switch (g) {
    case GradDiv::paper:
      return "paper";
    case GradDiv::navier:
      return "navier";
  }
  return "?";
}

const char* to_string(InitialState s) {
  switch (s) {
    case InitialState::rest:
      return "rest";
    case InitialState::sliding:
      return "sliding";
  }
  return "?";
}

const char* to_string(OutputFormat f) {
  switch (f) {
    case OutputFormat::csv:
      return "csv";
    case OutputFormat::hdf5:
      return "hdf5";
  }
  return "?";
}

const char* to_string(Method m) {
  if (m == Method::automatic) return "auto";
  return method_info(m).name;
}

const char* to_string(LinearSolver s) {
  if (s == LinearSolver::automatic) return "auto";
  return linear_solver_info(s).name;
}

Method validated_as(Method requested) {
  return requested == Method::automatic ? Method::imex : requested;
}

// Same sections and key names as the case file, so a summary.json can be read
// back as a case (apart from `source`).
nlohmann::json to_json(const Case& c) {
  using nlohmann::json;
  json contacts = json::array();
  for (const auto& k : c.interface.contacts)
    contacts.push_back({{"site", json::array({k.ix, k.iy})}, {"v_star", k.v_star}});
  auto selection = [](ContactSelection which, const std::vector<int>& ids) {
    return which == ContactSelection::all    ? json("all")
           : which == ContactSelection::none ? json("none")
                                             : json(ids);
  };
  json traces = selection(c.output.traces, c.output.trace_ids);
  const auto& l = c.lattice;
  const auto& m = c.material;
  const auto& i = c.interface;
  const auto& s = c.solver;
  json solver = {{"method", to_string(s.method)},
                 {"linear_solver", to_string(s.linear_solver)},
                 {"order", s.order},
                 {"step", s.step},
                 {"rtol", s.rtol},
                 {"max_steps", s.max_steps},
                 {"audit_bound", s.audit_bound},
                 {"threads", s.threads}};
  // Unset absolute tolerances follow rtol (integrate/tolerances.hpp); an
  // absent key reads back as unset.
  if (s.atol_displacement > 0) solver["atol_displacement"] = s.atol_displacement;
  if (s.atol_velocity > 0) solver["atol_velocity"] = s.atol_velocity;
  return {
      {"source", c.source.string()},
      {"lattice", {{"nx", l.nx}, {"ny", l.ny}, {"nz", l.nz}, {"spacing", l.spacing}}},
      {"material",
       {{"density", m.density},
        {"youngs_modulus", m.youngs_modulus},
        {"poisson_ratio", m.poisson_ratio},
        {"grad_div", to_string(m.grad_div)}}},
      {"damping", {{"bulk", c.damping.bulk}, {"contact", c.damping.contact}}},
      {"interface",
       {{"coverage", i.coverage},
        {"seed", i.seed},
        {"shear_stress", i.shear_stress},
        {"shape", i.shape},
        {"v_m", i.v_m},
        {"spread", i.spread},
        {"epsilon", i.epsilon},
        {"max_pressure", i.max_pressure},
        {"slip_threshold", i.slip_threshold},
        {"patch", i.patch},
        {"contacts", contacts}}},
      {"drive", {{"velocity", c.drive.velocity}}},
      {"run",
       {{"t_end", c.run.t_end},
        {"average_from", c.run.average_from},
        {"initial", to_string(c.run.initial)},
        {"checkpoint_every", c.run.checkpoint_every}}},
      {"solver", solver},
      {"output",
       {{"dir", c.output.dir.string()},
        {"interval", c.output.interval},
        {"max_rows", c.output.max_rows},
        {"traces", traces},
        {"events", selection(c.output.events, c.output.event_ids)},
        {"steps", c.output.steps},
        {"final_state", c.output.final_state},
        {"signals", c.output.signals},
        {"format", to_string(c.output.format)}}},
  };
}

int resolved_threads(const SolverParams& solver, std::int64_t nodes) {
  if (solver.threads > 0) return solver.threads;
  if (nodes < kMinNodesForThreads) return 1;
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

}  // namespace stickslip
