#pragma once
// What the integrator reports of each accepted step (IntegratorOptions::
// on_step) and, where the stepper is this project's own, of each attempt at
// one (on_attempt), apart from the integrator so the recorders that take
// them (output/recorder.hpp) need nothing else of it.

#include <array>
#include <cstddef>
#include <cstdint>

namespace stickslip {

// A column a stepper adds to steps.csv after the four every method writes
// (the stepper declares them: step_columns in make_integrator.hpp), its value
// in each StepRecord::method_values.
struct StepColumn {
  const char* name;
  const char* unit;  // "" for a count
  bool integer;
};
inline constexpr std::size_t kMaxStepColumns = 4;

// One accepted step: where it ended, its size, the weighted RMS norm of
// its local error estimate (≤ 1 for an accepted adaptive step; NaN where the
// method has no estimate), and h times the fastest growth rate of a contact
// past its peak force; then the values of its stepper's own columns.
struct StepRecord {
  double t = 0.0, h = 0.0, error = 0.0;
  double h_lambda = 0.0;  // h × System::weakening_rate at the step's end
  std::array<double, kMaxStepColumns> method_values{};
};

// One attempt at a coarse step of method = "multirate" (multirate_integrator.hpp):
// where it started, its size, its fast contacts, the coupling pass it ended
// in, what its error tests found and what it came to. A retry (a slow
// contact turned fast) repeats the step at the same H; a shrink repeats it
// shorter.
struct AttemptRecord {
  enum class Verdict {
    accepted,
    retry_turned_fast,    // a slow contact's own error exceeded 1
    retry_refused_stage,  // a slow contact's stage was refused (γλ > 1)
    shrink_error,         // the coarse error estimate exceeded 1
    shrink_miss,          // a stand-in's displacement missed its sub-steps' end
    shrink_coupling,      // Φ did not settle within the coupling passes
    shrink_substeps,      // a fast contact's sub-steps did not get through
    shrink_stage,         // a coarse stage did not converge
  };
  // The verdicts' names (attempts.csv's labels), in the enumerators' order.
  static constexpr std::array<const char*, 8> kVerdictNames{
      "accepted",    "retry_turned_fast", "retry_refused_stage", "shrink_error",
      "shrink_miss", "shrink_coupling",   "shrink_substeps",     "shrink_stage"};

  double t = 0.0, h = 0.0;
  long fast_contacts = 0;
  int coupling_pass = 0;  // 1, 2, ...: the pass the verdict came in
  // Weighted like a local error (≤ 1 to pass); NaN where the attempt did not
  // get as far as the test.
  double error = 0.0, coupling = 0.0, miss = 0.0;
  Verdict verdict = Verdict::accepted;
  // The state component that decided the verdict (System::describe_component):
  // the largest weighted error, the contact (its w_x) whose coupling, miss,
  // sub-steps or stage failed; −1 where none did.
  std::int64_t worst = -1;
};

}  // namespace stickslip
