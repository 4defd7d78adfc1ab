// The serial vector's replaced kernels (src/integrate/serial_vector_kernels.cpp)
// against SUNDIALS' own: every kernel bit for bit except the four-sum WRMS
// norm (to rounding), on lengths around the block sizes, with the output
// aliasing an input.
#include <nvector/nvector_serial.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "stickslip/integrate/serial_vector_kernels.hpp"
#include "stickslip/integrate/sundials.hpp"

using namespace stickslip;

namespace {

std::vector<double> random_values(std::size_t n, std::mt19937_64& gen) {
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  std::vector<double> v(n);
  for (auto& x : v) x = d(gen) * std::pow(10.0, 6 * d(gen));  // magnitudes 1e-6 to 1e6
  return v;
}

// SUNDIALS' own serial vector, with its original operations.
NVectorPtr plain_vector(const std::vector<double>& values, SUNContext ctx) {
  NVectorPtr v(N_VNew_Serial(static_cast<sunindextype>(values.size()), ctx));
  std::copy(values.begin(), values.end(), N_VGetArrayPointer_Serial(v.get()));
  return v;
}

std::vector<double> values_of(N_Vector v) {
  const auto s = as_span(v);
  return {s.begin(), s.end()};
}

}  // namespace

TEST_CASE("blocked linear combinations equal SUNDIALS' own, bit for bit, aliased or not",
          "[nvector][threads]") {
  // On 1 and 3 threads (ScopedKernelThreads): the longest vectors are split.
  const int threads = GENERATE(1, 3);
  INFO("threads " << threads);
  const ScopedKernelThreads kernels(threads);
  SunContext ctx;
  std::mt19937_64 gen(11);
  for (std::size_t n : {1u, 3u, 511u, 512u, 513u, 2049u, 3u * 16384u + 517u}) {
    for (int nvec : {1, 2, 3, 7, 13}) {
      std::vector<std::vector<double>> inputs;
      for (int i = 0; i < nvec; ++i) inputs.push_back(random_values(n, gen));
      std::vector<double> c = random_values(static_cast<std::size_t>(nvec), gen);
      // Reference: SUNDIALS' serial kernel into a separate output.
      std::vector<NVectorPtr> plain;
      std::vector<N_Vector> plain_x;
      for (const auto& in : inputs) {
        plain.push_back(plain_vector(in, ctx));
        plain_x.push_back(plain.back().get());
      }
      NVectorPtr expected_out = plain_vector(std::vector<double>(n, 0.0), ctx);
      REQUIRE(N_VLinearCombination(nvec, c.data(), plain_x.data(), expected_out.get()) == 0);
      const auto expected = values_of(expected_out.get());

      // Ours, into a separate output and into each of the inputs in turn.
      for (int alias = -1; alias < nvec; ++alias) {
        std::vector<NVectorPtr> ours;
        std::vector<N_Vector> ours_x;
        for (const auto& in : inputs) {
          ours.push_back(make_serial_vector(in, ctx));
          ours_x.push_back(ours.back().get());
        }
        NVectorPtr separate = make_serial_vector(std::vector<double>(n, 0.0), ctx);
        N_Vector z = alias < 0 ? separate.get() : ours_x[static_cast<std::size_t>(alias)];
        INFO("length " << n << ", " << nvec << " terms, output aliases input " << alias);
        REQUIRE(N_VLinearCombination(nvec, c.data(), ours_x.data(), z) == 0);
        CHECK(values_of(z) == expected);

        // SUNDIALS' fused serial kernel on copies aliased alike, where its
        // contract allows: z separate or z = X[0], for which it has paths of
        // its own (z = X[i], i > 0, is outside it and comes out wrong; ours, reading
        // each block whole before writing it, matches the separate output
        // there too, above). N_VLinearCombination ran the generic
        // N_VScale/N_VLinearSum loop for `expected`: the serial vector's
        // fused operations are off by default.
        if (alias > 0) continue;
        std::vector<NVectorPtr> theirs;
        std::vector<N_Vector> theirs_x;
        for (const auto& in : inputs) {
          theirs.push_back(plain_vector(in, ctx));
          theirs_x.push_back(theirs.back().get());
        }
        NVectorPtr their_separate = plain_vector(std::vector<double>(n, 0.0), ctx);
        N_Vector zt = alias < 0 ? their_separate.get() : theirs_x[static_cast<std::size_t>(alias)];
        REQUIRE(N_VLinearCombination_Serial(nvec, c.data(), theirs_x.data(), zt) == 0);
        CHECK(values_of(zt) == expected);
      }
    }
  }
}

TEST_CASE("the four-sum WRMS norm equals SUNDIALS' to rounding", "[nvector]") {
  SunContext ctx;
  std::mt19937_64 gen(5);
  for (std::size_t n : {1u, 2u, 3u, 4u, 5u, 7u, 1001u, 13503u}) {
    const auto x = random_values(n, gen), w = random_values(n, gen);
    NVectorPtr px = plain_vector(x, ctx), pw = plain_vector(w, ctx);
    NVectorPtr ox = make_serial_vector(x, ctx), ow = make_serial_vector(w, ctx);
    const double expected = N_VWrmsNorm(px.get(), pw.get()), ours = N_VWrmsNorm(ox.get(), ow.get());
    INFO("length " << n);
    CHECK(ours == Approx(expected).epsilon(1e-14));
    // and both against the definition, summed in long double
    long double sum = 0;
    for (std::size_t i = 0; i < n; ++i) sum += (long double)(x[i] * w[i]) * (x[i] * w[i]);
    CHECK(ours == Approx(static_cast<double>(std::sqrt(sum / n))).epsilon(1e-14));
    // x aliasing w (the norm of x² per entry): the same as SUNDIALS'.
    CHECK(N_VWrmsNorm(ox.get(), ox.get()) ==
          Approx(N_VWrmsNorm(px.get(), px.get())).epsilon(1e-14));
  }
}

TEST_CASE("clones keep the replaced kernels", "[nvector]") {
  // The integrators never use the vector they are given for their work
  // space: they clone it. A clone with SUNDIALS' own kernels would leave the
  // tests above checking code that never runs.
  SunContext ctx;
  NVectorPtr v = make_serial_vector(std::vector<double>(7, 1.0), ctx);
  NVectorPtr clone(N_VClone(v.get()));
  NVectorPtr plain = plain_vector(std::vector<double>(7, 1.0), ctx);
  CHECK(clone->ops->nvlinearcombination == v->ops->nvlinearcombination);
  CHECK(clone->ops->nvwrmsnorm == v->ops->nvwrmsnorm);
  CHECK(clone->ops->nvlinearsum == v->ops->nvlinearsum);
  CHECK(clone->ops->nvscaleaddmulti == v->ops->nvscaleaddmulti);
  CHECK(v->ops->nvlinearcombination != plain->ops->nvlinearcombination);
  CHECK(v->ops->nvwrmsnorm != plain->ops->nvwrmsnorm);
  CHECK(v->ops->nvlinearsum != plain->ops->nvlinearsum);
  CHECK(v->ops->nvconst != plain->ops->nvconst);
  CHECK(plain->ops->nvlinearcombination == nullptr);
}

namespace {

// A pair of vectors, one with SUNDIALS' kernels and one with ours, holding
// the same values; every operation is applied to both.
struct Twin {
  NVectorPtr plain, ours;
  Twin(const std::vector<double>& values, SUNContext ctx)
      : plain(plain_vector(values, ctx)), ours(make_serial_vector(values, ctx)) {}
};

// Bit for bit: == would take −0 for +0 (and never match a NaN).
void check_same(const Twin& t) {
  const auto ours = values_of(t.ours.get()), plain = values_of(t.plain.get());
  REQUIRE(ours.size() == plain.size());
  CHECK(std::memcmp(ours.data(), plain.data(), ours.size() * sizeof(double)) == 0);
}

// Random values with exact zeros, ties and signed zeros among them, where the
// kernels branch.
std::vector<double> values_with_zeros(std::size_t n, std::mt19937_64& gen) {
  auto v = random_values(n, gen);
  for (std::size_t i = 0; i < n; i += 5) v[i] = 0.0;
  for (std::size_t i = 2; i < n; i += 7) v[i] = -0.0;
  for (std::size_t i = 3; i < n; i += 11) v[i] = 1.0;
  return v;
}

}  // namespace

TEST_CASE("the linear sum equals SUNDIALS' bit for bit in each of its special cases",
          "[nvector][threads]") {
  const int threads = GENERATE(1, 3);
  INFO("threads " << threads);
  const ScopedKernelThreads kernels(threads);
  SunContext ctx;
  std::mt19937_64 gen(3);
  const double c = 0.37, d = -2.9;
  const std::pair<double, double> coefficients[] = {{1, 1},  {1, -1}, {-1, 1}, {-1, -1}, {c, c},
                                                    {c, -c}, {1, d},  {d, 1},  {-1, d},  {d, -1},
                                                    {c, d},  {0, d},  {c, 0},  {0, 0},   {-c, c}};
  for (std::size_t n : {1u, 7u, 1000u, 2u * 16384u + 9u}) {
    const auto x = random_values(n, gen);
    auto y = random_values(n, gen);
    // Entries where y = x and y = −x: there the special cases differ from
    // a x + b y in the sign of a zero result.
    for (std::size_t i = 0; i < n; i += 3) y[i] = i % 2 == 0 ? x[i] : -x[i];
    for (auto [a, b] : coefficients)
      for (int alias : {0, 1, 2}) {  // z separate, z = x, z = y
        INFO("a = " << a << ", b = " << b << ", alias " << alias);
        Twin tx(x, ctx), ty(y, ctx), tz(std::vector<double>(n, 5.0), ctx);
        Twin& z = alias == 0 ? tz : alias == 1 ? tx : ty;
        N_VLinearSum(a, tx.plain.get(), b, ty.plain.get(), z.plain.get());
        N_VLinearSum(a, tx.ours.get(), b, ty.ours.get(), z.ours.get());
        check_same(z);
      }
  }
}

TEST_CASE("the element-wise kernels and reductions equal SUNDIALS' bit for bit",
          "[nvector][threads]") {
  const int threads = GENERATE(1, 3);
  INFO("threads " << threads);
  const ScopedKernelThreads kernels(threads);
  SunContext ctx;
  std::mt19937_64 gen(7);
  for (std::size_t n : {1u, 2u, 5u, 513u, 13503u, 2u * 16384u + 3u}) {
    INFO("length " << n);
    const auto x = values_with_zeros(n, gen), y = values_with_zeros(n, gen);
    auto nonzero = random_values(n, gen);
    const auto out = std::vector<double>(n, 3.0);
    auto each = [&](auto&& op) {  // op(x, y, z) on SUNDIALS' vectors, then ours
      Twin tx(x, ctx), ty(nonzero, ctx), tz(out, ctx);
      op(tx.plain.get(), ty.plain.get(), tz.plain.get());
      op(tx.ours.get(), ty.ours.get(), tz.ours.get());
      check_same(tz);
    };
    each([](N_Vector, N_Vector, N_Vector z) { N_VConst(-4.25, z); });
    each([](N_Vector a, N_Vector b, N_Vector z) { N_VProd(a, b, z); });
    each([](N_Vector a, N_Vector b, N_Vector z) { N_VDiv(a, b, z); });
    each([](N_Vector a, N_Vector, N_Vector z) { N_VScale(-0.3, a, z); });
    each([](N_Vector a, N_Vector, N_Vector z) { N_VScale(1.0, a, z); });
    each([](N_Vector a, N_Vector, N_Vector z) { N_VAbs(a, z); });
    each([](N_Vector, N_Vector b, N_Vector z) { N_VInv(b, z); });
    each([](N_Vector a, N_Vector, N_Vector z) { N_VAddConst(a, 0.125, z); });
    each([](N_Vector a, N_Vector, N_Vector z) { N_VCompare(0.5, a, z); });
    // InvTest leaves z where x = 0, and says whether it met one.
    {
      Twin tx(x, ctx), tz(out, ctx);
      CHECK(N_VInvTest(tx.ours.get(), tz.ours.get()) == N_VInvTest(tx.plain.get(), tz.plain.get()));
      check_same(tz);
    }
    // ConstrMask with every kind of constraint, met and violated.
    {
      std::vector<double> constraints(n);
      const double kinds[] = {0.0, 1.0, -1.0, 2.0, -2.0};
      for (std::size_t i = 0; i < n; ++i) constraints[i] = kinds[(i * 7 + 3) % 5];
      Twin tc(constraints, ctx), tx(x, ctx), tm(out, ctx);
      CHECK(N_VConstrMask(tc.ours.get(), tx.ours.get(), tm.ours.get()) ==
            N_VConstrMask(tc.plain.get(), tx.plain.get(), tm.plain.get()));
      check_same(tm);
    }
    Twin tx(x, ctx), ty(y, ctx), tw(nonzero, ctx), tid(values_with_zeros(n, gen), ctx);
    CHECK(N_VDotProd(tx.ours.get(), ty.ours.get()) == N_VDotProd(tx.plain.get(), ty.plain.get()));
    CHECK(N_VMaxNorm(tx.ours.get()) == N_VMaxNorm(tx.plain.get()));
    CHECK(N_VMin(tx.ours.get()) == N_VMin(tx.plain.get()));
    CHECK(N_VWL2Norm(tx.ours.get(), tw.ours.get()) == N_VWL2Norm(tx.plain.get(), tw.plain.get()));
    CHECK(N_VL1Norm(tx.ours.get()) == N_VL1Norm(tx.plain.get()));
    CHECK(N_VWrmsNormMask(tx.ours.get(), tw.ours.get(), tid.ours.get()) ==
          N_VWrmsNormMask(tx.plain.get(), tw.plain.get(), tid.plain.get()));
    CHECK(N_VMinQuotient(tw.ours.get(), tx.ours.get()) ==
          N_VMinQuotient(tw.plain.get(), tx.plain.get()));
  }
}

TEST_CASE("the fused multi-vector kernels equal SUNDIALS' generic loops bit for bit",
          "[nvector][threads]") {
  // With the serial vector's fused operations off (its default), SUNDIALS'
  // N_VScaleAddMulti and N_VDotProdMulti loop over N_VLinearSum and N_VDotProd.
  const int threads = GENERATE(1, 3);
  INFO("threads " << threads);
  const ScopedKernelThreads kernels(threads);
  SunContext ctx;
  std::mt19937_64 gen(13);
  for (std::size_t n : {1u, 9u, 2049u, 2u * 16384u + 1u})
    for (int nvec : {1, 2, 5}) {
      INFO("length " << n << ", " << nvec << " vectors");
      const auto x = random_values(n, gen);
      auto a = random_values(static_cast<std::size_t>(nvec), gen);
      a[0] = 1.0;  // the linear sum's own branch
      if (nvec > 1) a[1] = -1.0;
      std::vector<Twin> y, z;
      for (int i = 0; i < nvec; ++i) {
        y.emplace_back(random_values(n, gen), ctx);
        z.emplace_back(std::vector<double>(n, 0.0), ctx);
      }
      Twin tx(x, ctx);
      for (bool in_place : {false, true}) {
        std::vector<N_Vector> yp, yo, zp, zo;
        for (int i = 0; i < nvec; ++i) {
          yp.push_back(y[i].plain.get());
          yo.push_back(y[i].ours.get());
          zp.push_back(in_place ? yp.back() : z[i].plain.get());
          zo.push_back(in_place ? yo.back() : z[i].ours.get());
        }
        REQUIRE(N_VScaleAddMulti(nvec, a.data(), tx.plain.get(), yp.data(), zp.data()) == 0);
        REQUIRE(N_VScaleAddMulti(nvec, a.data(), tx.ours.get(), yo.data(), zo.data()) == 0);
        for (int i = 0; i < nvec; ++i) check_same(in_place ? y[i] : z[i]);
        std::vector<double> dots_plain(nvec), dots_ours(nvec);
        REQUIRE(N_VDotProdMulti(nvec, tx.plain.get(), yp.data(), dots_plain.data()) == 0);
        REQUIRE(N_VDotProdMulti(nvec, tx.ours.get(), yo.data(), dots_ours.data()) == 0);
        CHECK(dots_ours == dots_plain);
      }
    }
}
