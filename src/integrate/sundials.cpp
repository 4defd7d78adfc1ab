#include "stickslip/integrate/sundials.hpp"

#include <algorithm>
#include <string>

namespace stickslip {

void check(int flag, const char* call) {
  if (flag < 0)
    throw IntegrationError(std::string(call) + " failed with flag " + std::to_string(flag));
}

void check_created(const void* p, const char* call) {
  if (p == nullptr) throw IntegrationError(std::string(call) + " returned NULL");
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
  std::copy(values.begin(), values.end(), N_VGetArrayPointer_Serial(v));
  return owned;
}

}  // namespace stickslip
