#include "stickslip/integrate/sundials.hpp"

#include <sunmatrix/sunmatrix_sparse.h>

#include <algorithm>
#include <cstdio>
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

void print_solver_message(int error_code, const char* module, const char* function, char* msg,
                          void*) {
  constexpr int kTooMuchWork = -1;  // ARK_TOO_MUCH_WORK and CV_TOO_MUCH_WORK
  if (error_code == kTooMuchWork) return;
  std::fprintf(stderr, "[%s %s] %s: %s\n", module, error_code < 0 ? "ERROR" : "WARNING", function,
               msg);
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

static_assert(std::is_same_v<sunindextype, std::int64_t>,
              "SparseJacobian's indices are copied into SUNDIALS' sparse matrix as they are");

void copy_into(const SparseJacobian& jac, SUNMatrix m) {
  std::copy(jac.row_start.begin(), jac.row_start.end(), SUNSparseMatrix_IndexPointers(m));
  std::copy(jac.column.begin(), jac.column.end(), SUNSparseMatrix_IndexValues(m));
  std::copy(jac.value.begin(), jac.value.end(), SUNSparseMatrix_Data(m));
}

MatrixPtr make_sparse_matrix(const SparseJacobian& jac, SUNContext ctx) {
  SUNMatrix m = SUNSparseMatrix(jac.size, jac.size, jac.nonzeros(), CSR_MAT, ctx);
  check_created(m, "SUNSparseMatrix");
  MatrixPtr owned(m);
  copy_into(jac, m);
  return owned;
}

}  // namespace stickslip
