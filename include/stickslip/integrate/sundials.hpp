#pragma once
// RAII ownership of SUNDIALS objects and the one exception boundary every
// C callback goes through. Nothing here knows about the physics but its one
// recoverable failure, StageNotConverged (model/friction_law.hpp).

#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>

#include <exception>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>

#include "stickslip/integrate/errors.hpp"

namespace stickslip {

// Throws IntegrationError naming `call` when a SUNDIALS call returns < 0.
// Calls on an integrator's memory use SteppingIntegrator::check instead,
// which adds the flag's name and the message SUNDIALS reported.
void check(int flag, const char* call);
// Throws when a constructor returned NULL.
void check_created(const void* p, const char* call);

class SunContext {
 public:
  SunContext();
  ~SunContext();
  SunContext(const SunContext&) = delete;
  SunContext& operator=(const SunContext&) = delete;
  operator SUNContext() const { return ctx_; }

 private:
  SUNContext ctx_ = nullptr;
};

struct NVectorDeleter {
  void operator()(N_Vector v) const { N_VDestroy(v); }
};
// An ARKStep memory block held outside an adapter (ARKStepFree; defined with
// the ARKStep adapter). The adapters own theirs through their package's table
// of calls (stepping_integrator.hpp).
struct ArkodeMemDeleter {
  void operator()(void* mem) const;
};
using NVectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, NVectorDeleter>;
using ArkodeMemPtr = std::unique_ptr<void, ArkodeMemDeleter>;

NVectorPtr make_serial_vector(std::span<const double> values, SUNContext ctx);

// The last error message SUNDIALS reported to one integrator, kept for the
// IntegrationError that reports the failure: its error handler's user data.
class SolverMessage {
 public:
  void record(std::string text) { text_ = std::move(text); }
  // The message, forgotten once taken ("" if none since the last take).
  std::string take() { return std::exchange(text_, {}); }

 private:
  std::string text_;
};

// Error handler for ARKODE and CVODE, its user data a SolverMessage: an
// error's message, "[module] function: text", goes into it (and so into the
// exception), not to stderr; warnings are printed like the default handler's.
// "Too much work" (flag −1 in both), which the adapters use on purpose to
// return every poll interval of steps (case/methods.hpp), is dropped.
void record_solver_message(int error_code, const char* module, const char* function, char* msg,
                           void* solver_message);

// A package's name of a return flag, from ARKStepGetReturnFlagName or
// CVodeGetReturnFlagName (which allocate it; freed here).
std::string flag_name(char* (*package_name)(long int), int flag);

inline std::span<double> as_span(N_Vector v) {
  return {N_VGetArrayPointer_Serial(v), static_cast<std::size_t>(N_VGetLength_Serial(v))};
}

// The one exception boundary, as deal.II's call_and_possibly_capture_exception:
// every C callback (right-hand sides, root functions, the stage solver) runs
// its C++ code through guarded(), so no exception ever crosses a SUNDIALS
// frame. It returns what SUNDIALS' callbacks return:
//    0  success;
//    1  recoverable: the body threw StageNotConverged (model/friction_law.hpp), a
//       stage solve that did not converge or was refused, which a smaller
//       step cures; the package retries with a smaller step where its
//       callback allows it (the stage solver turns 1 into SUN_NLS_CONV_RECVR,
//       exact_stage_solver.cpp);
//   −1  unrecoverable: any other exception, stored in `slot` and rethrown by
//       the adapter after the SUNDIALS call returns.
// The right-hand side, the roots and the Jacobian are defined at every finite
// state, and a state that is not finite is a failed run (run.cpp), not a step
// to retry: they throw nothing recoverable.

// Inside a catch block: 1 for StageNotConverged, else stores the exception in
// `slot` and returns −1.
int capture_exception(std::exception_ptr& slot) noexcept;

template <class Body>
int guarded(std::exception_ptr& slot, Body&& body) noexcept {
  try {
    body();
    return 0;
  } catch (...) {
    return capture_exception(slot);
  }
}

}  // namespace stickslip
