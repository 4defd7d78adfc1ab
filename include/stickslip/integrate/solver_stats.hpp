#pragma once
// What an integrator reports of its work, accumulated over a run (and over
// its restarts: a checkpoint carries the statistics so far).

#include <nlohmann/json.hpp>

namespace stickslip {

struct SolverStats {
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
  // multirate: the fast contacts' sub-steps (accepted, rejected), the
  // contacts a coarse step left to their sub-steps (summed over the steps),
  // and the coarse steps redone for their coupling.
  long substeps = 0;
  long substep_failures = 0;
  long fast_contact_steps = 0;
  long coupling_iterations = 0;
  // multirate: the energy the partition itself makes [J]. The lattice does
  // work on a fast contact's stand-in along the node's coarse path, the
  // contact dissipates along its sub-steps'; where its force changes within
  // a coarse step the two differ. Where slips are lone, this summed over the
  // run is, but for the coarse steps' own error, the energy audit's residual
  // times the drive's work; in block slips it is a part of it
  // (docs/PERFORMANCE.md, "The μ floor, what it is and what it is not").
  double partition_work = 0.0;
};

// JSON with one field per member, both ways (summary.json, checkpoints). A
// field missing from an older file reads as zero (krylov_iterations and the
// multirate counts and partition_work came later).
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(SolverStats, steps, step_attempts, rhs_explicit,
                                                rhs_implicit, newton_iterations,
                                                convergence_failures, linear_setups,
                                                jacobian_evaluations, krylov_iterations,
                                                error_test_failures, root_evaluations, last_step,
                                                substeps, substep_failures, fast_contact_steps,
                                                coupling_iterations, partition_work)

// The statistics of a run continued from a checkpoint: counts add up, the
// last step is the later run's.
SolverStats& operator+=(SolverStats& a, const SolverStats& b);

}  // namespace stickslip
