// The exact stage solver's contract with ARKStep (exact_stage_solver.hpp): a
// stage solve that does not converge makes the integrator retry with a
// smaller step; any other exception stops the integration and is handed back.
// On y' = −λ y, fully implicit, whose stage z − γ(−λ z) = b has the exact
// solution z = b / (1 + γ λ).
#include <arkode/arkode_arkstep.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <stdexcept>

#include "stickslip/integrate/exact_stage_solver.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/model/system.hpp"

using namespace stickslip;

namespace {

constexpr double kLambda = 1e3;

int decay(double, N_Vector y, N_Vector ydot, void*) {
  N_VScale(-kLambda, y, ydot);
  return 0;
}

struct Problem {
  SunContext ctx;
  NVectorPtr y = make_serial_vector(std::vector<double>{1.0}, ctx);
  ArkodeMemPtr mem{ARKStepCreate(nullptr, decay, 0.0, y.get(), ctx)};
  StageStats stats;
  std::exception_ptr pending;
  NonlinearSolverPtr nls;

  explicit Problem(ExactStageSolve solve) {
    nls = make_exact_stage_solver(ctx, StagePackage::arkstep, std::move(solve), stats, pending);
    check(ARKStepSStolerances(mem.get(), 1e-8, 1e-12), "ARKStepSStolerances");
    check(ARKStepSetNonlinearSolver(mem.get(), nls.get()), "ARKStepSetNonlinearSolver");
    check(ARKStepSetInitStep(mem.get(), 1e-3), "ARKStepSetInitStep");
    // The unrecoverable failure below is expected: keep stderr quiet.
    check(ARKStepSetErrHandlerFn(
              mem.get(), [](int, const char*, const char*, char*, void*) {}, nullptr),
          "ARKStepSetErrHandlerFn");
  }
  int evolve(double t_out) {
    double t = 0.0;
    return ARKStepEvolve(mem.get(), t_out, y.get(), &t, ARK_NORMAL);
  }
};

}  // namespace

TEST_CASE("a stage solve that does not converge makes the step smaller", "[stage]") {
  // Refuses every stage whose γ λ exceeds 0.05: the integrator must shrink
  // its step below that and still reach the exact solution.
  double largest_tried = 0.0, largest_solved = 0.0;
  Problem p([&](double, double gamma, std::span<const double>, std::span<const double>,
                std::span<double> z) -> long {
    largest_tried = std::max(largest_tried, gamma);
    if (gamma * kLambda > 0.05) throw StageNotConverged("step too large for this test");
    largest_solved = std::max(largest_solved, gamma);
    z[0] /= 1.0 + gamma * kLambda;
    return 1;
  });
  REQUIRE(p.evolve(5e-3) >= 0);
  CHECK(p.stats.failures > 0);
  CHECK(largest_tried * kLambda > 0.05);  // it did try larger steps, and was refused
  CHECK(largest_solved * kLambda <= 0.05);
  CHECK(N_VGetArrayPointer(p.y.get())[0] == Approx(std::exp(-kLambda * 5e-3)).epsilon(1e-6));
  CHECK_FALSE(p.pending);
}

TEST_CASE("any other exception in a stage solve stops the integration with it", "[stage]") {
  Problem p([](double, double, std::span<const double>, std::span<const double>,
               std::span<double>) -> long { throw std::out_of_range("index 7 of 3"); });
  CHECK(p.evolve(5e-3) < 0);
  CHECK(p.stats.failures == 0);  // not counted as a convergence failure, not retried
  REQUIRE(p.pending);
  CHECK_THROWS_AS(std::rethrow_exception(p.pending), std::out_of_range);
}

TEST_CASE("every callback's one boundary returns 0, 1 (recoverable) or -1", "[stage]") {
  std::exception_ptr slot;
  CHECK(guarded(slot, [] {}) == 0);
  CHECK_FALSE(slot);
  // A stage that did not converge is recoverable in any callback: nothing to
  // rethrow, the package retries with a smaller step.
  CHECK(guarded(slot, [] { throw StageNotConverged("too large a step"); }) == 1);
  CHECK_FALSE(slot);
  CHECK(guarded(slot, [] { throw std::out_of_range("index 7 of 3"); }) == -1);
  REQUIRE(slot);
  CHECK_THROWS_AS(std::rethrow_exception(slot), std::out_of_range);
}
