#include "stickslip/integrate/sundials.hpp"

#include <sunmatrix/sunmatrix_sparse.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <type_traits>

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

namespace {

// z = Σ c_i X_i in blocks that stay in L1, reading each X_i once and writing z
// once. ARKStep forms every stage and both solutions this way, up to 13 terms
// for the ARK4(3) IMEX pair; the serial vector's own version makes one pass
// over z per term, and these combinations took half of an imex step on
// 15×15×10 (perf). z may be one of the X_i: a block is read whole before it
// is written.
int blocked_linear_combination(int nvec, sunrealtype* c, N_Vector* X, N_Vector z) {
  constexpr sunindextype kBlock = 512;
  const sunindextype n = NV_LENGTH_S(z);
  double* zd = NV_DATA_S(z);
  double sum[kBlock];
  for (sunindextype start = 0; start < n; start += kBlock) {
    const sunindextype len = std::min(kBlock, n - start);
    const double* x0 = NV_DATA_S(X[0]) + start;
    for (sunindextype j = 0; j < len; ++j) sum[j] = c[0] * x0[j];
    for (int i = 1; i < nvec; ++i) {
      const double* xi = NV_DATA_S(X[i]) + start;
      const double ci = c[i];
      for (sunindextype j = 0; j < len; ++j) sum[j] += ci * xi[j];
    }
    std::copy(sum, sum + len, zd + start);
  }
  return 0;
}

// The weighted RMS norm of every error test, with four partial sums: the
// serial vector's single running sum is a chain of dependent additions, and
// this norm (twice per step) took 14 % of an imex step once the combinations
// above were blocked.
sunrealtype wrms_norm(N_Vector x, N_Vector w) {
  const sunindextype n = NV_LENGTH_S(x);
  const double* xd = NV_DATA_S(x);
  const double* wd = NV_DATA_S(w);
  double s[4] = {0.0, 0.0, 0.0, 0.0};
  sunindextype j = 0;
  for (; j + 4 <= n; j += 4)
    for (int k = 0; k < 4; ++k) {
      const double p = xd[j + k] * wd[j + k];
      s[k] += p * p;
    }
  for (; j < n; ++j) s[0] += (xd[j] * wd[j]) * (xd[j] * wd[j]);
  return std::sqrt(((s[0] + s[1]) + (s[2] + s[3])) / static_cast<double>(n));
}

}  // namespace

NVectorPtr make_serial_vector(std::span<const double> values, SUNContext ctx) {
  N_Vector v = N_VNew_Serial(static_cast<sunindextype>(values.size()), ctx);
  check_created(v, "N_VNew_Serial");
  NVectorPtr owned(v);
  // Clones inherit these.
  v->ops->nvlinearcombination = blocked_linear_combination;
  v->ops->nvwrmsnorm = wrms_norm;
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
