#include "stickslip/integrate/sundials.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <type_traits>

#include "stickslip/integrate/serial_vector_kernels.hpp"
#include "stickslip/model/system.hpp"

namespace stickslip {

void check(int flag, const char* call) {
  if (flag < 0)
    throw IntegrationError(std::string(call) + " failed with flag " + std::to_string(flag));
}

void check_created(const void* p, const char* call) {
  if (p == nullptr) throw IntegrationError(std::string(call) + " returned NULL");
}

int capture_exception(std::exception_ptr& slot) noexcept {
  try {
    throw;
  } catch (const StageNotConverged&) {
    return 1;
  } catch (...) {
    slot = std::current_exception();
    return -1;
  }
}

void record_solver_message(int error_code, const char* module, const char* function, char* msg,
                           void* solver_message) {
  constexpr int kTooMuchWork = -1;  // ARK_TOO_MUCH_WORK and CV_TOO_MUCH_WORK
  if (error_code == kTooMuchWork) return;
  if (error_code < 0 && solver_message != nullptr) {
    static_cast<SolverMessage*>(solver_message)
        ->record("[" + std::string(module) + "] " + function + ": " + msg);
    return;
  }
  std::fprintf(stderr, "[%s %s] %s: %s\n", module, error_code < 0 ? "ERROR" : "WARNING", function,
               msg);
}

std::string flag_name(char* (*package_name)(long int), int flag) {
  char* name = package_name(flag);
  if (name == nullptr) return "flag " + std::to_string(flag);
  std::string owned(name);
  std::free(name);
  return owned;
}

SunContext::SunContext() {
  check(SUNContext_Create(nullptr, &ctx_), "SUNContext_Create");
}
SunContext::~SunContext() {
  SUNContext_Free(&ctx_);
}

NVectorPtr make_serial_vector(std::span<const double> values, SUNContext ctx) {
  N_Vector v = N_VNew_Serial(static_cast<sunindextype>(values.size()), ctx);
  check_created(v, "N_VNew_Serial");
  NVectorPtr owned(v);
  use_compiled_kernels(v);  // clones inherit them
  std::copy(values.begin(), values.end(), N_VGetArrayPointer_Serial(v));
  return owned;
}

}  // namespace stickslip
