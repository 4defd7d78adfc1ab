#pragma once
// RAII ownership of SUNDIALS objects and the one exception boundary every
// C callback goes through. Nothing here knows about the physics.

#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>

#include <exception>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

namespace stickslip {

// Thrown when an integrator fails; `what()` says where (time) and why.
class IntegrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws IntegrationError naming `call` when a SUNDIALS call returns < 0.
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
// The integrators' memory blocks (ARKStepFree, CVodeFree; defined with the adapters).
struct ArkodeMemDeleter {
  void operator()(void* mem) const;
};
struct CvodeMemDeleter {
  void operator()(void* mem) const;
};
using NVectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, NVectorDeleter>;
using ArkodeMemPtr = std::unique_ptr<void, ArkodeMemDeleter>;
using CvodeMemPtr = std::unique_ptr<void, CvodeMemDeleter>;

NVectorPtr make_serial_vector(std::span<const double> values, SUNContext ctx);

// Error handler for ARKODE and CVODE: prints their messages like the default
// handler, except "too much work" (flag −1 in both), which the adapters use
// on purpose to return every poll interval of steps (case/methods.hpp).
void print_solver_message(int error_code, const char* module, const char* function, char* msg,
                          void* user_data);

inline std::span<double> as_span(N_Vector v) {
  return {N_VGetArrayPointer_Serial(v), static_cast<std::size_t>(N_VGetLength_Serial(v))};
}

// The exception boundary: runs `body` inside a C callback. Returns 0 on
// success; on a C++ exception stores it in `slot` (rethrown by the adapter
// after the SUNDIALS call returns) and returns −1, so no exception ever
// crosses a SUNDIALS frame. It never returns 1 (recoverable): the failures a
// smaller step cures are stage solves that do not converge or are refused,
// and those return SUN_NLS_CONV_RECVR from the stage solver
// (exact_stage_solver.cpp). The right-hand side, the roots and the Jacobian
// are defined at every finite state, and a state that is not finite is a
// failed run (run.cpp), not a step to retry.

template <class Body>
int guarded(std::exception_ptr& slot, Body&& body) noexcept {
  try {
    body();
    return 0;
  } catch (...) {
    slot = std::current_exception();
    return -1;
  }
}

}  // namespace stickslip
