// The whole-cycle mean of a friction signal, on signals whose mean over whole
// cycles is known exactly: a sawtooth (the block-scale stick-slip's shape), a
// sine, a constant.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/core/cycles.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/run/run.hpp"
#include "temp_dir.hpp"

using namespace stickslip;

namespace {

struct Signal {
  std::vector<double> t, f;
};

// f rises linearly from lo to hi over each period and drops back within one
// sample, sampled every dt over [0, t_end]: its mean over whole cycles is
// (lo + hi) / 2.
Signal sawtooth(double period, double lo, double hi, double dt, double t_end, double phase = 0) {
  Signal s;
  for (long k = 0; k * dt <= t_end + 1e-12; ++k) {
    const double t = k * dt, x = std::fmod(t + phase, period) / period;
    s.t.push_back(t);
    s.f.push_back(lo + (hi - lo) * x);
  }
  return s;
}

double plain_mean(const Signal& s, double t_from) {
  double sum = 0, span = 0;
  for (std::size_t i = 0; i + 1 < s.t.size(); ++i)
    if (s.t[i] >= t_from) {
      sum += 0.5 * (s.f[i] + s.f[i + 1]) * (s.t[i + 1] - s.t[i]);
      span += s.t[i + 1] - s.t[i];
    }
  return sum / span;
}

}  // namespace

TEST_CASE("sawtooth: whole cycles give (lo + hi) / 2 where the window is biased",
          "[analysis][cycles]") {
  // 4.9 ms period, sampled every 10 µs, window [10, 30] ms: 4.08 cycles.
  const double T = 4.9e-3, lo = 2.0, hi = 6.0, dt = 1e-5;
  double worst_window_bias = 0;
  for (int k = 0; k < 20; ++k) {
    const double phase = k * T / 20;
    const Signal s = sawtooth(T, lo, hi, dt, 30e-3, phase);
    const CycleMean r = whole_cycle_mean(s.t, s.f, 10e-3);
    INFO("phase " << phase);
    // Sampled, the drop takes one interval dt: the mean of the sampled
    // sawtooth is off by (hi − lo)/2 · dt/T, whatever the window.
    CHECK(std::abs(r.mean - 4.0) <= (hi - lo) / 2 * dt / T * 1.01);
    // Whole cycles between the crossings, inside the window.
    CHECK(r.from >= 10e-3);
    CHECK(r.to <= 30e-3);
    const double cycles = (r.to - r.from) / T;
    CHECK(std::abs(cycles - std::round(cycles)) < dt / T);
    CHECK(r.crossings == std::lround(cycles) + 1);
    worst_window_bias = std::max(worst_window_bias, std::abs(plain_mean(s, 10e-3) - 4.0));
  }
  // The test can fail: the plain window mean is off by up to
  // (hi − lo)/2 · 0.08 cycle / 4.08 cycles ≈ 0.039 at some phase.
  CHECK(worst_window_bias > 0.03);
}

TEST_CASE("sine: the mean over whole periods is its offset", "[analysis][cycles]") {
  Signal s;
  const double T = 3e-3;
  for (long k = 0; k <= 20000; ++k) {
    const double t = k * 1e-6;
    s.t.push_back(t);
    s.f.push_back(1.5 + 0.7 * std::sin(2 * M_PI * t / T + 0.4));
  }
  const CycleMean r = whole_cycle_mean(s.t, s.f, 1e-3);
  CHECK(r.mean == Approx(1.5).epsilon(1e-6));
  CHECK(r.crossings == 7);  // 1.31, 4.31, … 19.31 ms
  CHECK(std::abs(plain_mean(s, 1e-3) - 1.5) > 1e-3);
}

TEST_CASE("relative spread: a sine's amplitude over sqrt 2 over its offset", "[analysis][cycles]") {
  // 4.0 + 0.3 sin(2π t / 5 ms), sampled every 1e-5 s over 20 whole periods after t_from = 1e-2:
  // sd/mean = 0.3/√2/4.0 up to the sample sd's (n − 1) and the sampling.
  std::vector<double> t, f;
  for (int i = 0; i <= 11000; ++i) {
    t.push_back(i * 1e-5);
    f.push_back(4.0 + 0.3 * std::sin(2 * M_PI * t.back() / 5e-3) +
                (t.back() < 1e-2 ? 100.0 : 0.0));  // a start the window must leave out
  }
  f.pop_back();
  t.pop_back();  // exactly 20 periods: samples 1000 … 10999
  CHECK(relative_spread(t, f, 1e-2) == Approx(0.3 / std::sqrt(2.0) / 4.0).epsilon(1e-3));
  CHECK(relative_spread(std::vector<double>(5, 1.0), std::vector<double>(5, 2.5), 0.0) == 0.0);
  CHECK_THROWS_AS(relative_spread(t, f, 1.0), std::invalid_argument);
}

TEST_CASE("no cycle: a constant or a ramp gives the window mean", "[analysis][cycles]") {
  const std::vector<double> t = {0, 1, 2, 3, 4}, flat = {2, 2, 2, 2, 2}, ramp = {0, 1, 2, 3, 4};
  const CycleMean c = whole_cycle_mean(t, flat, 1.0);
  CHECK(c.mean == 2.0);
  CHECK(c.crossings == 0);
  CHECK(c.from == 1.0);
  CHECK(c.to == 4.0);
  const CycleMean r = whole_cycle_mean(t, ramp, 0.5);  // samples from t = 1 count
  CHECK(r.mean == 2.5);
  CHECK(r.crossings == 0);
}

TEST_CASE("whole_cycle_mean refuses too few samples and mismatched sizes", "[analysis][cycles]") {
  const std::vector<double> t = {0, 1, 2}, f = {1, 2};
  CHECK_THROWS_AS(whole_cycle_mean(t, f, 0.0), std::invalid_argument);
  const std::vector<double> g = {1, 2, 3};
  CHECK_THROWS_AS(whole_cycle_mean(t, g, 1.5), std::invalid_argument);
}

namespace {

WindowRegime regime_of(const Signal& s, double t_from) {
  return classify_window(s.t, s.f, t_from, whole_cycle_mean(s.t, s.f, t_from),
                         relative_spread(s.t, s.f, t_from));
}

}  // namespace

TEST_CASE("the window's regime: whole cycles, steady, a loading ramp, or a cycle cut short",
          "[analysis][cycles]") {
  // Five whole sawtooth cycles: stick-slip, μ trusted, and no drift over whole cycles.
  const WindowRegime cycles = regime_of(sawtooth(1e-3, 1.0, 2.0, 1e-6, 6e-3), 1e-3);
  CHECK(cycles.kind == Regime::stick_slip);
  CHECK(cycles.mu_trusted());

  // A ramp 1 → 3 over the window: its line explains all of it, drift (3 − 1)/2 exactly.
  Signal ramp;
  for (int k = 0; k <= 1000; ++k)
    ramp.t.push_back(k * 1e-6), ramp.f.push_back(1.0 + 2e3 * k * 1e-6);
  const WindowRegime loading = regime_of(ramp, 0.0);
  CHECK(loading.kind == Regime::loading);
  CHECK_FALSE(loading.mu_trusted());
  CHECK(loading.drift == Approx(1.0).epsilon(1e-12));
  CHECK(loading.trend_share == Approx(1.0).epsilon(1e-12));
  // With ringing on it slower than the ramp's rise (what a block loaded from
  // rest shows): F_f never falls, so no downward crossing: still a ramp.
  Signal ringing = ramp;
  for (std::size_t k = 0; k < ringing.t.size(); ++k)
    ringing.f[k] += 0.02 * std::sin(2 * M_PI * ringing.t[k] / 1e-4);
  CHECK(whole_cycle_mean(ringing.t, ringing.f, 0.0).crossings == 0);
  CHECK(regime_of(ringing, 0.0).kind == Regime::loading);

  // Constant to 1e-4 relative: steady sliding, trusted.
  Signal steady;
  for (int k = 0; k <= 1000; ++k)
    steady.t.push_back(k * 1e-6), steady.f.push_back(5.0 * (1 + 1e-4 * std::sin(k * 0.37)));
  CHECK(regime_of(steady, 0.0).kind == Regime::steady_sliding);
  CHECK(regime_of(steady, 0.0).mu_trusted());

  // One drop in the middle of the window, no whole cycle: neither ramp nor steady.
  const WindowRegime cut = regime_of(sawtooth(1e-3, 1.0, 2.0, 1e-6, 1e-3, 5e-4), 0.0);
  CHECK(cut.kind == Regime::unsettled);
  CHECK_FALSE(cut.mu_trusted());
  CHECK(std::string(to_string(Regime::steady_sliding)) == "steady sliding");
}

TEST_CASE("a run from rest: a window on its loading is flagged, a later one of slips is not",
          "[slow][analysis][cycles]") {
  // 18 random contacts on 6x6x4 at v = 1e-3: the block loads for ~4 ms before
  // the first slip (F_f rising 67 % across [1, 2] ms), then stick-slips.
  test::TempDir dir("stickslip_test_regime");
  Case c;
  c.lattice = {6, 6, 4, 1e-4};
  c.interface.coverage = 0.5;
  c.output.events = ContactSelection::none;
  c.run.t_end = 2e-3;
  c.run.average_from = 1e-3;
  const Summary early = run_case(c, {dir.path / "early", false, true});
  REQUIRE(early.regime);
  CHECK(early.regime->kind == Regime::loading);
  CHECK(early.regime->drift > 0.5);
  CHECK_THAT(mu_warning(early), Catch::Contains("rises as a ramp"));
  REQUIRE(early.warnings.size() == 1);  // the default rtol is not loose
  CHECK(early.warnings[0].about == "mu");
  c.run.t_end = 8e-3;
  c.run.average_from = 4e-3;
  const Summary late = run_case(c, {dir.path / "late", false, true});
  REQUIRE(late.regime);
  CHECK(late.regime->kind == Regime::stick_slip);
  CHECK(mu_warning(late).empty());
  CHECK(late.warnings.empty());
}
