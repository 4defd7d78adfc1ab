#include "stickslip/integrate/solver_stats.hpp"

#include <string>

namespace stickslip {

long SolverStats::count(std::string_view name) const {
  const auto it = method.find(std::string(name));
  return it == method.end() ? 0 : it->get<long>();
}

double SolverStats::amount(std::string_view name) const {
  const auto it = method.find(std::string(name));
  return it == method.end() ? 0.0 : it->get<double>();
}

void to_json(nlohmann::json& j, const SolverStats& s) {
  j = static_cast<const SolverCounts&>(s);
  for (const auto& [name, value] : s.method.items()) j[name] = value;
}

void from_json(const nlohmann::json& j, SolverStats& s) {
  static_cast<SolverCounts&>(s) = j.get<SolverCounts>();
  const nlohmann::json counts = SolverCounts{};
  s.method = nlohmann::json::object();
  for (const auto& [name, value] : j.items())
    if (!counts.contains(name) && value.is_number() && value != 0) s.method[name] = value;
}

SolverStats& operator+=(SolverStats& a, const SolverStats& b) {
  a.steps += b.steps;
  a.step_attempts += b.step_attempts;
  a.rhs_explicit += b.rhs_explicit;
  a.rhs_implicit += b.rhs_implicit;
  a.newton_iterations += b.newton_iterations;
  a.convergence_failures += b.convergence_failures;
  a.linear_setups += b.linear_setups;
  a.jacobian_evaluations += b.jacobian_evaluations;
  a.krylov_iterations += b.krylov_iterations;
  a.error_test_failures += b.error_test_failures;
  a.root_evaluations += b.root_evaluations;
  for (const auto& [name, value] : b.method.items()) {
    auto& sum = a.method[name];
    if (sum.is_null())
      sum = value;
    else if (sum.is_number_integer() && value.is_number_integer())
      sum = sum.get<long>() + value.get<long>();
    else
      sum = sum.get<double>() + value.get<double>();
  }
  if (b.last_step != 0.0) a.last_step = b.last_step;
  return a;
}

}  // namespace stickslip
