#pragma once
// What the integrator reports of each accepted step (IntegratorOptions::
// on_step), apart from the integrator so the recorders that take it
// (output/recorder.hpp) need nothing else of it.

namespace stickslip {

// One accepted step: where it ended, its size, the weighted RMS norm of
// its local error estimate (≤ 1 for an accepted adaptive step; NaN where the
// method has no estimate), and h times the fastest growth rate of a contact
// past its peak force.
struct StepRecord {
  double t = 0.0, h = 0.0, error = 0.0;
  double h_lambda = 0.0;  // h × System::weakening_rate at the step's end
  // multirate: the contacts this step left to their own sub-steps, and those
  // sub-steps (0 for the other methods).
  long fast_contacts = 0, substeps = 0;
  // multirate: how far the coarse node of a fast contact missed its
  // sub-steps' end, as its neighbours felt it, weighted as a local error
  // (≤ 1; 0 where no contact was apart). error is the larger of it and the
  // coarse estimate, so it says which of the two sized the step.
  double miss = 0.0;
};

}  // namespace stickslip
