#include "stickslip/integrate/serial_vector_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "stickslip/model/parallel_for.hpp"

// Why this file exists: Debian's SUNDIALS 6.4.1 is compiled without
// optimization (its serial kernels keep every loop variable on the stack:
// `objdump -d libsundials_nvecserial.so.6.4.1`), and a linear sum of two
// vectors of 13 503 entries took 24 µs there against 3.8 µs for the same loop
// compiled here (docs/notes/performance-history.md). ARKODE and CVODE do all their
// per-entry work through the vector's operations table, so the kernels below
// replace the serial vector's entries for every vector the integrators make.
//
// Each computes exactly what SUNDIALS' serial kernel computes, in the same
// order, so results are bit for bit the same (tests/test_nvector.cpp); the
// exceptions, said where they are, are the blocked linear combination (the
// same sums, one pass) and the four-sum WRMS norm (equal to rounding).

namespace stickslip {
namespace {

// Threads for the elementwise loops of the run driving this thread
// (ScopedKernelThreads), and the block of entries each thread takes at a
// time. Vectors shorter than two blocks stay serial: 15×15×10's 13 503
// entries take ~4 µs a pass, the cost of waking a thread.
thread_local int kernel_threads = 1;
constexpr sunindextype kThreadBlock = 16384;

// f(start, len) over [0, n) in blocks of kThreadBlock, on kernel_threads.
template <class Block>
void for_blocks(sunindextype n, Block&& f) {
  const sunindextype blocks = (n + kThreadBlock - 1) / kThreadBlock;
  if (kernel_threads <= 1 || blocks < 2) {
    f(0, n);
    return;
  }
  parallel_for(kernel_threads, blocks, [&](std::int64_t b) {
    f(b * kThreadBlock, std::min(kThreadBlock, n - b * kThreadBlock));
  });
}

double* data(N_Vector v) {
  return NV_DATA_S(v);
}
sunindextype length(N_Vector v) {
  return NV_LENGTH_S(v);
}

// z = a x + b y, through SUNDIALS' special cases in its order: they give
// the same values as a x + b y but for the sign of a zero result (y − x
// against −(x − y)) and for a = ±b, where it forms a (x ± y).
void linear_sum(double a, N_Vector x, double b, N_Vector y, N_Vector z) {
  const sunindextype n = length(z);
  const double* xd = data(x);
  const double* yd = data(y);
  double* zd = data(z);
  auto each = [&](auto&& f) {
    for_blocks(n, [&](sunindextype start, sunindextype len) {
      for (sunindextype i = start; i < start + len; ++i) zd[i] = f(xd[i], yd[i]);
    });
  };
  if (a == 1.0 && b == 1.0)
    each([](double u, double v) { return u + v; });
  else if (a == 1.0 && b == -1.0)
    each([](double u, double v) { return u - v; });
  else if (a == -1.0 && b == 1.0)
    each([](double u, double v) { return v - u; });
  else if (a == 1.0)
    each([b](double u, double v) { return b * v + u; });
  else if (b == 1.0)
    each([a](double u, double v) { return a * u + v; });
  else if (a == -1.0)
    each([b](double u, double v) { return b * v - u; });
  else if (b == -1.0)
    each([a](double u, double v) { return a * u - v; });
  else if (a == b)
    each([a](double u, double v) { return a * (u + v); });
  else if (a == -b)
    each([a](double u, double v) { return a * (u - v); });
  else
    each([a, b](double u, double v) { return a * u + b * v; });
}

void constant(double c, N_Vector z) {
  double* zd = data(z);
  for_blocks(length(z),
             [&](sunindextype start, sunindextype len) { std::fill_n(zd + start, len, c); });
}

void product(N_Vector x, N_Vector y, N_Vector z) {
  const double *xd = data(x), *yd = data(y);
  double* zd = data(z);
  for (sunindextype i = 0, n = length(z); i < n; ++i) zd[i] = xd[i] * yd[i];
}

void quotient(N_Vector x, N_Vector y, N_Vector z) {
  const double *xd = data(x), *yd = data(y);
  double* zd = data(z);
  for (sunindextype i = 0, n = length(z); i < n; ++i) zd[i] = xd[i] / yd[i];
}

void scale(double c, N_Vector x, N_Vector z) {
  const double* xd = data(x);
  double* zd = data(z);
  for_blocks(length(z), [&](sunindextype start, sunindextype len) {
    for (sunindextype i = start; i < start + len; ++i) zd[i] = c * xd[i];
  });
}

void absolute(N_Vector x, N_Vector z) {
  const double* xd = data(x);
  double* zd = data(z);
  for (sunindextype i = 0, n = length(z); i < n; ++i) zd[i] = std::abs(xd[i]);
}

void inverse(N_Vector x, N_Vector z) {
  const double* xd = data(x);
  double* zd = data(z);
  for (sunindextype i = 0, n = length(z); i < n; ++i) zd[i] = 1.0 / xd[i];
}

void add_constant(N_Vector x, double b, N_Vector z) {
  const double* xd = data(x);
  double* zd = data(z);
  for (sunindextype i = 0, n = length(z); i < n; ++i) zd[i] = xd[i] + b;
}

// The reductions sum in SUNDIALS' order (one running sum: without
// -ffast-math the compiler keeps it), so they are bit for bit its own.
double dot_product(N_Vector x, N_Vector y) {
  const double *xd = data(x), *yd = data(y);
  double sum = 0.0;
  for (sunindextype i = 0, n = length(x); i < n; ++i) sum += xd[i] * yd[i];
  return sum;
}

double max_norm(N_Vector x) {
  const double* xd = data(x);
  double max = 0.0;
  for (sunindextype i = 0, n = length(x); i < n; ++i) max = std::max(max, std::abs(xd[i]));
  return max;
}

// The weighted RMS norm of every error test, with four partial sums: a
// single running sum is a chain of dependent additions, and this norm (twice
// per step) took 14 % of an imex step once the combinations were blocked.
// Equal to SUNDIALS' to rounding, not bit for bit.
double wrms_norm(N_Vector x, N_Vector w) {
  const sunindextype n = length(x);
  const double *xd = data(x), *wd = data(w);
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

double wrms_norm_mask(N_Vector x, N_Vector w, N_Vector id) {
  const double *xd = data(x), *wd = data(w), *idd = data(id);
  const sunindextype n = length(x);
  double sum = 0.0;
  for (sunindextype i = 0; i < n; ++i)
    if (idd[i] > 0.0) {
      const double p = xd[i] * wd[i];
      sum += p * p;
    }
  return std::sqrt(sum / static_cast<double>(n));
}

double minimum(N_Vector x) {
  const double* xd = data(x);
  double min = xd[0];
  for (sunindextype i = 1, n = length(x); i < n; ++i)
    if (xd[i] < min) min = xd[i];
  return min;
}

double weighted_l2_norm(N_Vector x, N_Vector w) {
  const double *xd = data(x), *wd = data(w);
  double sum = 0.0;
  for (sunindextype i = 0, n = length(x); i < n; ++i) {
    const double p = xd[i] * wd[i];
    sum += p * p;
  }
  return std::sqrt(sum);
}

double l1_norm(N_Vector x) {
  const double* xd = data(x);
  double sum = 0.0;
  for (sunindextype i = 0, n = length(x); i < n; ++i) sum += std::abs(xd[i]);
  return sum;
}

void compare(double c, N_Vector x, N_Vector z) {
  const double* xd = data(x);
  double* zd = data(z);
  for (sunindextype i = 0, n = length(z); i < n; ++i) zd[i] = std::abs(xd[i]) >= c ? 1.0 : 0.0;
}

// z = 1/x where x ≠ 0 (z keeps its entries where x = 0); false if any x = 0.
sunbooleantype inverse_test(N_Vector x, N_Vector z) {
  const double* xd = data(x);
  double* zd = data(z);
  bool no_zero = true;
  for (sunindextype i = 0, n = length(z); i < n; ++i) {
    if (xd[i] == 0.0)
      no_zero = false;
    else
      zd[i] = 1.0 / xd[i];
  }
  return no_zero ? SUNTRUE : SUNFALSE;
}

// m = 1 where x violates its constraint c (±1: x ≥ 0 / ≤ 0; ±2: > 0 / < 0).
sunbooleantype constraint_mask(N_Vector c, N_Vector x, N_Vector m) {
  const double *cd = data(c), *xd = data(x);
  double* md = data(m);
  bool all_met = true;
  for (sunindextype i = 0, n = length(x); i < n; ++i) {
    md[i] = 0.0;
    if (cd[i] == 0.0) continue;
    const bool violated = (std::abs(cd[i]) > 1.5 && xd[i] * cd[i] <= 0.0) ||
                          (std::abs(cd[i]) > 0.5 && xd[i] * cd[i] < 0.0);
    if (violated) {
      md[i] = 1.0;
      all_met = false;
    }
  }
  return all_met ? SUNTRUE : SUNFALSE;
}

double min_quotient(N_Vector num, N_Vector denom) {
  const double *nd = data(num), *dd = data(denom);
  double min = std::numeric_limits<double>::max();  // SUN_BIG_REAL
  bool first = true;
  for (sunindextype i = 0, n = length(num); i < n; ++i) {
    if (dd[i] == 0.0) continue;
    const double q = nd[i] / dd[i];
    min = first ? q : (min < q ? min : q);  // SUNMIN's choice on ties and NaN
    first = false;
  }
  return min;
}

// z = Σ c_i X_i in blocks that stay in L1, reading each X_i once and writing z
// once. ARKStep forms every stage and both solutions this way, up to 13 terms
// for the ARK4(3) IMEX pair; the serial vector's own version makes one pass
// over z per term. The sums are SUNDIALS' (c_0 X_0 + c_1 X_1 + …, in order),
// bit for bit. z may be one of the X_i: a block is read whole before it is
// written.
int linear_combination(int nvec, sunrealtype* c, N_Vector* X, N_Vector z) {
  constexpr sunindextype kBlock = 512;
  const sunindextype n = length(z);
  double* zd = data(z);
  for_blocks(n, [&](sunindextype first, sunindextype count) {
    double sum[kBlock];
    for (sunindextype start = first; start < first + count; start += kBlock) {
      const sunindextype len = std::min(kBlock, first + count - start);
      const double* x0 = data(X[0]) + start;
      for (sunindextype j = 0; j < len; ++j) sum[j] = c[0] * x0[j];
      for (int i = 1; i < nvec; ++i) {
        const double* xi = data(X[i]) + start;
        const double ci = c[i];
        for (sunindextype j = 0; j < len; ++j) sum[j] += ci * xi[j];
      }
      std::copy(sum, sum + len, zd + start);
    }
  });
  return 0;
}

// Z_i = a_i x + Y_i (CVODE's history updates), as N_VLinearSum(a_i, x, 1, Y_i)
// computes it.
int scale_add_multi(int nvec, sunrealtype* a, N_Vector x, N_Vector* Y, N_Vector* Z) {
  const double* xd = data(x);
  const sunindextype n = length(x);
  for (int i = 0; i < nvec; ++i) {
    const double* yd = data(Y[i]);
    double* zd = data(Z[i]);
    const double ai = a[i];
    for_blocks(n, [&](sunindextype start, sunindextype len) {
      for (sunindextype j = start; j < start + len; ++j) zd[j] = ai * xd[j] + yd[j];
    });
  }
  return 0;
}

int dot_product_multi(int nvec, N_Vector x, N_Vector* Y, sunrealtype* dots) {
  for (int i = 0; i < nvec; ++i) dots[i] = dot_product(x, Y[i]);
  return 0;
}

}  // namespace

ScopedKernelThreads::ScopedKernelThreads(int threads) : previous_(kernel_threads) {
  kernel_threads = threads;
}
ScopedKernelThreads::~ScopedKernelThreads() {
  kernel_threads = previous_;
}

void use_compiled_kernels(N_Vector v) {
  N_Vector_Ops ops = v->ops;
  ops->nvlinearsum = linear_sum;
  ops->nvconst = constant;
  ops->nvprod = product;
  ops->nvdiv = quotient;
  ops->nvscale = scale;
  ops->nvabs = absolute;
  ops->nvinv = inverse;
  ops->nvaddconst = add_constant;
  ops->nvdotprod = dot_product;
  ops->nvmaxnorm = max_norm;
  ops->nvwrmsnorm = wrms_norm;
  ops->nvwrmsnormmask = wrms_norm_mask;
  ops->nvmin = minimum;
  ops->nvwl2norm = weighted_l2_norm;
  ops->nvl1norm = l1_norm;
  ops->nvcompare = compare;
  ops->nvinvtest = inverse_test;
  ops->nvconstrmask = constraint_mask;
  ops->nvminquotient = min_quotient;
  ops->nvlinearcombination = linear_combination;
  ops->nvscaleaddmulti = scale_add_multi;
  ops->nvdotprodmulti = dot_product_multi;
}

}  // namespace stickslip
