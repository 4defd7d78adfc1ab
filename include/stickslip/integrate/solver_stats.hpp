#pragma once
// What an integrator reports of its work, accumulated over a run (and over
// its restarts: a checkpoint carries the statistics so far).

#include <nlohmann/json.hpp>
#include <string_view>

namespace stickslip {

// What every method counts (each package's or stepper's own name for it
// aside).
struct SolverCounts {
  long steps = 0;
  long step_attempts = 0;
  long rhs_explicit = 0;       // evaluations of the explicit part (erk, rk4, imex)
  long rhs_implicit = 0;       // evaluations of the implicit part (imex, dirk, bdf)
  long newton_iterations = 0;  // imex: scalar iterations of the per-contact stage solves
  long convergence_failures = 0;
  long linear_setups = 0;  // dirk, bdf (fft): lattice factorizations M(γ)
  long jacobian_evaluations =
      0;                       // dirk, bdf (fft): LU factorizations of the contacts' Newton matrix
  long krylov_iterations = 0;  // dirk, bdf (fft): Krylov iterations on the contacts' Newton steps
  long error_test_failures = 0;
  long root_evaluations = 0;
  double last_step = 0.0;
};

// JSON with one field per member, both ways. A field missing from an older
// file reads as zero (krylov_iterations came later).
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(SolverCounts, steps, step_attempts, rhs_explicit,
                                                rhs_implicit, newton_iterations,
                                                convergence_failures, linear_setups,
                                                jacobian_evaluations, krylov_iterations,
                                                error_test_failures, root_evaluations, last_step)

struct SolverStats : SolverCounts {
  // What only one method counts, by name, each summed over the run: its
  // stepper names and fills them (MultirateIntegrator::stats: its sub-steps,
  // fast contact-steps, coupling passes and partition work), and
  // summary.json writes them beside the counts above. Integer counts stay
  // integers.
  nlohmann::json method = nlohmann::json::object();

  // The method's count or amount `name`; 0 where the method keeps none.
  long count(std::string_view name) const;
  double amount(std::string_view name) const;
};

// The counts and the method's own, side by side in one object. Reading, a
// field that is not a count is the method's own (a zero one from a file of a
// method that wrote every method's fields is dropped).
void to_json(nlohmann::json& j, const SolverStats& s);
void from_json(const nlohmann::json& j, SolverStats& s);

// The statistics of a run continued from a checkpoint: counts add up, the
// last step is the later run's.
SolverStats& operator+=(SolverStats& a, const SolverStats& b);

}  // namespace stickslip
