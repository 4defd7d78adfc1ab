// The whole-cycle mean of a friction signal, on signals whose mean over whole
// cycles is known exactly: a sawtooth (the block-scale stick-slip's shape), a
// sine, a constant.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/core/cycles.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/tables.hpp"
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

CycleMean whole_cycle_mean(const Signal& s, double t_from) {
  return analyse_window(s.t, s.f, t_from, true).cycles;
}

WindowRegime regime_of(const Signal& s, double t_from) {
  return analyse_window(s.t, s.f, t_from, true).regime;
}

// A sawtooth whose every drop is followed by ringing: a decaying oscillation
// of `ring` times the drop, period 20 µs (what the lattice does after a block slip).
Signal ringing_sawtooth(double period, double lo, double hi, double dt, double t_end, double ring) {
  Signal s = sawtooth(period, lo, hi, dt, t_end);
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    const double since = std::fmod(s.t[k], period);
    s.f[k] += ring * (hi - lo) * std::exp(-since / 1e-4) * std::sin(2 * M_PI * since / 2e-5);
  }
  return s;
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
    const CycleMean r = whole_cycle_mean(s, 10e-3);
    INFO("phase " << phase);
    // Sampled, the drop takes one interval dt: the mean of the sampled
    // sawtooth is off by (hi − lo)/2 · dt/T, whatever the window.
    CHECK(std::abs(r.mean - 4.0) <= (hi - lo) / 2 * dt / T * 1.01);
    // Whole cycles between block slips' onsets, inside the window, one period apart.
    CHECK(r.from >= 10e-3);
    CHECK(r.to <= 30e-3);
    const double cycles = (r.to - r.from) / T;
    CHECK(std::abs(cycles - std::round(cycles)) < dt / T);
    CHECK(r.block_slips == std::lround(cycles) + 1);
    CHECK(r.period == Approx(T).epsilon(dt / T));
    // Identical cycles: their means agree to the sampling, so the error is nil.
    CHECK(r.error < 1e-3);
    worst_window_bias = std::max(worst_window_bias, std::abs(plain_mean(s, 10e-3) - 4.0));
  }
  // The test can fail: the plain window mean is off by up to
  // (hi − lo)/2 · 0.08 cycle / 4.08 cycles ≈ 0.039 at some phase.
  CHECK(worst_window_bias > 0.03);
}

TEST_CASE("ringing after a block slip is no cycle", "[analysis][cycles]") {
  // Block cycle 0.3 ms, ringing 15 % of the drop (as after a block slip on 8×8×5).
  const double T = 3e-4;
  const Signal s = ringing_sawtooth(T, 2.0, 6.0, 1e-6, 6e-3, 0.15);
  // The run's block slips are the drops, one per period, nothing in the ringing.
  const auto slips = find_block_slips(s.t, s.f);
  REQUIRE(slips.size() == 20);  // at 0.3, 0.6, … 6.0 ms (the last sample is past its drop)
  for (std::size_t k = 0; k < slips.size(); ++k) {
    CHECK(slips[k].onset == Approx((k + 1) * T).margin(2e-6));
    CHECK(slips[k].drop > 0.95 * 4.0);  // the sawtooth's fall, sampled
  }
  // Two-thirds of a cycle after a drop: ringing, no whole cycle, so no
  // verdict of stick-slip and no whole-cycle mean (the old crossings of the
  // mean counted the ringing's).
  Signal part;
  for (std::size_t k = 0; k < s.t.size(); ++k)
    if (s.t[k] <= 3.2e-3) part.t.push_back(s.t[k]), part.f.push_back(s.f[k]);
  const FrictionWindow w = analyse_window(part.t, part.f, 3.0e-3 + 1e-6, true);
  CHECK(w.cycles.block_slips == 0);
  CHECK(std::isnan(w.cycles.period));
  CHECK(w.regime.kind == Regime::unsettled);
  CHECK_FALSE(w.regime.mu_trusted());
  // Over the whole run after the first slip: the period is the sawtooth's.
  const CycleMean all = whole_cycle_mean(s, 1e-3);
  CHECK(all.period == Approx(T).epsilon(1e-2));
  CHECK(all.block_slips == 17);  // 1.2, 1.5, … 6.0 ms
}

TEST_CASE("sine: the mean over whole periods is its offset", "[analysis][cycles]") {
  Signal s;
  const double T = 3e-3;
  for (long k = 0; k <= 20000; ++k) {
    const double t = k * 1e-6;
    s.t.push_back(t);
    s.f.push_back(1.5 + 0.7 * std::sin(2 * M_PI * t / T + 0.4));
  }
  const CycleMean r = whole_cycle_mean(s, 1e-3);
  CHECK(r.mean == Approx(1.5).epsilon(1e-6));
  // Peaks (block slips' onsets) at 0.559 + 3k ms: six in [1, 20] ms, five whole periods.
  CHECK(r.block_slips == 6);
  CHECK(r.period == Approx(T).epsilon(1e-3));
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

TEST_CASE("no block slip: a constant or a ramp gives the window mean", "[analysis][cycles]") {
  std::vector<double> t, flat, ramp;
  for (int k = 0; k <= 40; ++k) t.push_back(k), flat.push_back(2), ramp.push_back(k);
  const FrictionWindow c = analyse_window(t, flat, 1.0, true);
  CHECK(c.mean == 2.0);
  CHECK(c.cycles.block_slips == 0);
  CHECK(c.cycles.from == 1.0);
  CHECK(c.cycles.to == 40.0);
  CHECK(c.regime.kind == Regime::steady_sliding);
  const FrictionWindow r = analyse_window(t, ramp, 0.5, true);  // samples from t = 1 count
  CHECK(r.mean == 20.5);
  CHECK(r.cycles.block_slips == 0);
  CHECK(r.regime.kind == Regime::loading);
  CHECK(std::isnan(r.regime.transient_ends));  // no block slip: the ramp has not ended
}

TEST_CASE("the analysis refuses mismatched sizes", "[analysis][cycles]") {
  const std::vector<double> t = {0, 1, 2}, f = {1, 2};
  CHECK_THROWS_AS(analyse_window(t, f, 0.0, true), std::invalid_argument);
  CHECK_THROWS_AS(find_block_slips(t, f), std::invalid_argument);
  CHECK_THROWS_AS(settled_from(t, f), std::invalid_argument);
}

TEST_CASE("the window's regime: whole cycles, steady, a loading ramp, or a cycle cut short",
          "[analysis][cycles]") {
  // Five whole sawtooth cycles: stick-slip, μ trusted, and no drift over whole cycles.
  const WindowRegime cycles = regime_of(sawtooth(1e-3, 1.0, 2.0, 1e-6, 6e-3), 1e-3 - 1e-6);
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
  // rest shows): F never falls by more than the ringing, so no block slip: still a ramp.
  Signal ringing = ramp;
  for (std::size_t k = 0; k < ringing.t.size(); ++k)
    ringing.f[k] += 0.02 * std::sin(2 * M_PI * ringing.t[k] / 1e-4);
  CHECK(find_block_slips(ringing.t, ringing.f).empty());
  CHECK(regime_of(ringing, 0.0).kind == Regime::loading);

  // Constant to 1e-4 relative: steady sliding, trusted.
  Signal steady;
  for (int k = 0; k <= 1000; ++k)
    steady.t.push_back(k * 1e-6), steady.f.push_back(5.0 * (1 + 1e-4 * std::sin(k * 0.37)));
  CHECK(regime_of(steady, 0.0).kind == Regime::steady_sliding);
  CHECK(regime_of(steady, 0.0).mu_trusted());

  // Before the trace's first block slip F rises: whatever the window holds
  // after it, a window that starts there starts on the loading.
  const WindowRegime before = regime_of(sawtooth(1e-3, 1.0, 2.0, 1e-6, 1e-3, 5e-4), 0.0);
  CHECK(before.kind == Regime::loading);
  CHECK(before.transient_ends == Approx(5e-4).margin(1e-6));
  // After it, one drop in the window, no whole cycle: neither ramp nor steady.
  const WindowRegime cut = regime_of(sawtooth(1e-3, 1.0, 2.0, 1e-6, 2.5e-3), 1.2e-3);
  CHECK(cut.kind == Regime::unsettled);
  CHECK_FALSE(cut.mu_trusted());
  CHECK(std::string(to_string(Regime::steady_sliding)) == "steady sliding");
}

TEST_CASE("a window partly on the loading ramp is loading, and says where the ramp ends",
          "[analysis][cycles]") {
  // From rest F rises 0 → 6 over 4.9 ms, then a sawtooth 2 → 6 of period
  // 3 ms: the first block slip's onset is 4.9 ms. A window [1, 8] ms holds
  // two block slips (the old test of two crossings called it stick-slip).
  Signal s;
  const double dt = 1e-5, t_first = 4.9e-3, T = 3e-3;
  for (long k = 0; k * dt <= 40e-3 + 1e-12; ++k) {
    const double t = k * dt;
    s.t.push_back(t);
    s.f.push_back(t <= t_first ? 6.0 * t / t_first : 2.0 + 4.0 * std::fmod(t - t_first, T) / T);
  }
  const FrictionWindow early = analyse_window(s.t, s.f, 1e-3, true);
  CHECK(early.regime.kind == Regime::loading);
  CHECK(early.regime.transient_ends == Approx(t_first).margin(dt));
  CHECK(early.cycles.block_slips >= 2);
  // After the ramp: whole cycles, trusted, and the mean over whole cycles is (2 + 6)/2.
  const FrictionWindow late = analyse_window(s.t, s.f, 10e-3, true);
  CHECK(late.regime.kind == Regime::stick_slip);
  CHECK(std::isnan(late.regime.transient_ends));
  // (the sampled drop takes one interval: off by (6 − 2)/2 · dt/T at most)
  CHECK(late.cycles.mean == Approx(4.0).margin(2.0 * dt / T * 1.01));
  // "auto": the first block slip's onset (the cycles after it are alike).
  CHECK(settled_from(s.t, s.f) == Approx(t_first).margin(dt));
}

TEST_CASE("MSER over the cycles cuts leading cycles that bias the mean", "[analysis][cycles]") {
  // Ten cycles of 1 ms after a ramp; the first three sit 1.0 higher (a
  // transient), the rest alike: the settled window starts at the fourth onset.
  Signal s;
  const double dt = 1e-6;
  for (long k = 0; k * dt <= 11e-3 + 1e-12; ++k) {
    const double t = k * dt;
    s.t.push_back(t);
    if (t <= 1e-3) {
      s.f.push_back(7.0 * t / 1e-3);
    } else {
      const double c = std::floor((t - 1e-3) / 1e-3), x = std::fmod(t - 1e-3, 1e-3) / 1e-3;
      s.f.push_back((c < 3 ? 3.0 : 2.0) + 4.0 * x);
    }
  }
  const auto slips = find_block_slips(s.t, s.f);
  REQUIRE(slips.size() >= 10);
  CHECK(settled_from(s.t, s.f) == Approx(4e-3).margin(2 * dt));
}

TEST_CASE("the error of the mean: batch means over block cycles, or the autocorrelation",
          "[analysis][cycles]") {
  // 1 ms cycles whose means alternate 4 + a and 4 − a: over seven whole
  // cycles (four of one, three of the other) the mean is 4 ± a/7 and the
  // batch-means error √(7/6 · (4 (6a/7)² + 3 (8a/7)²)) / 7 = √8 a / 7.
  Signal s;
  const double dt = 1e-6, a = 0.25;
  for (long k = 0; k * dt <= 9e-3 + 1e-12; ++k) {
    const double t = k * dt, c = std::floor(t / 1e-3), x = std::fmod(t, 1e-3) / 1e-3;
    s.t.push_back(t);
    s.f.push_back((static_cast<long>(c) % 2 ? 4.0 - a : 4.0 + a) - 2.0 + 4.0 * x);
  }
  const FrictionWindow w = analyse_window(s.t, s.f, 0.5e-3, true);
  REQUIRE(w.cycles.block_slips == 8);  // onsets at 1, 2, … 8 ms (the 9 ms peak ends the trace)
  CHECK(w.cycles.error == Approx(std::sqrt(8.0) * a / 7).epsilon(2e-3));
  CHECK(std::string(w.error_from) == "block cycles");

  // AR(1) noise x_k = φ x_k−1 + e_k about 5: statistical inefficiency (1 + φ)/(1 − φ) = 19.
  std::vector<double> x(400000), t(x.size());
  std::uint64_t state = 12345;
  auto uniform = [&] {  // SplitMix64: the same sequence on every platform
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53 - 0.5;
  };
  double xi = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    xi = 0.9 * xi + uniform() * 0.01;
    x[k] = 5.0 + xi;
    t[k] = static_cast<double>(k) * 1e-6;
  }
  CHECK(statistical_inefficiency(x) == Approx(19.0).epsilon(0.1));
  CHECK(statistical_inefficiency(std::vector<double>(100, 1.0)) == 1.0);
  const FrictionWindow noise = analyse_window(t, x, 0.0, true);
  CHECK(std::string(noise.error_from) == "autocorrelation");
  // Var(mean) = σ² g / n, σ² = var(e)/(1 − φ²) = (0.01²/12)/0.19.
  CHECK(noise.error == Approx(std::sqrt(0.01 * 0.01 / 12 / 0.19 * 19 / x.size())).epsilon(0.1));
}

TEST_CASE("a verdict for every window, with the fix that applies", "[analysis][cycles]") {
  const Signal s = sawtooth(3e-3, 2.0, 6.0, 1e-5, 40e-3);
  // Undriven: nothing to average, whatever F does.
  CHECK(analyse_window(s.t, s.f, 10e-3, false).regime.kind == Regime::not_driven);
  // One sample, or none, in the window: still judged (undersampled), never left out.
  const FrictionWindow one = analyse_window(s.t, s.f, 40e-3, true);
  CHECK(one.samples == 1);
  CHECK(one.regime.kind == Regime::undersampled);
  const FrictionWindow none = analyse_window(s.t, s.f, 41e-3, true);
  CHECK(none.samples == 0);
  CHECK(none.regime.kind == Regime::undersampled);
  // Sixteen cycles sampled every 1e-3 s: three samples a cycle, too coarse to
  // see them (the old verdict: unsettled, "run longer", which cannot help).
  Signal coarse;
  for (std::size_t k = 0; k < s.t.size(); k += 100)
    coarse.t.push_back(s.t[k]), coarse.f.push_back(s.f[k]);
  const FrictionWindow c = analyse_window(coarse.t, coarse.f, 5e-3, true);
  CHECK(c.regime.kind == Regime::undersampled);
  CHECK_FALSE(c.regime.mu_trusted());
}

namespace {

// 18 random contacts on 6x6x4 at v = 1e-3, from rest: the block loads for
// ~4 ms before its first block slip (F_f rising 67 % across [1, 2] ms), then
// stick-slips, a block slip every ~2.7 ms.
Case small_block_from_rest() {
  Case c;
  c.lattice = {6, 6, 4, 1e-4};
  c.interface.coverage = 0.5;
  c.output.events = ContactSelection::none;
  return c;
}

}  // namespace

TEST_CASE("a run from rest: a window on its loading is flagged, a later one of slips is not",
          "[slow][analysis][cycles]") {
  test::TempDir dir("stickslip_test_regime");
  Case c = small_block_from_rest();
  c.run.t_end = 2e-3;
  c.run.average_from = 1e-3;
  const Summary early = run_case(c, {dir.path / "early", false, true});
  REQUIRE(early.regime);
  CHECK(early.regime->kind == Regime::loading);
  CHECK(early.regime->drift > 0.5);
  CHECK_THAT(mu_warning(early), Catch::Contains("rises as a ramp"));
  REQUIRE(early.warnings.size() == 1);  // the default rtol is not loose
  CHECK(early.warnings[0].about == "mu");
  // The first block slip's onset is at 4.16 ms: a window from 4 ms starts on
  // the ramp; one from 4.2 ms to 10 ms holds the next two block slips.
  c.run.t_end = 10e-3;
  c.run.average_from = 4.2e-3;
  const Summary late = run_case(c, {dir.path / "late", false, true});
  REQUIRE(late.regime);
  CHECK(late.regime->kind == Regime::stick_slip);
  CHECK(mu_warning(late).empty());
  CHECK(late.warnings.empty());
  CHECK(std::isfinite(late.mu_error));

  // "auto": the window starts at a block slip's onset (the run's own list),
  // not before the first, and μ is the friction impulse from there: the
  // table's impulse column at that row, over F_N and the window.
  c.run.average_auto = true;
  c.run.average_from = 0.0;
  c.output.events = ContactSelection::all;
  const Summary automatic = run_case(c, {dir.path / "auto", false, true});
  // The contacts' slip statistics cover the window found, as μ does.
  REQUIRE(automatic.events);
  CHECK(automatic.events->window_from == automatic.average_from);
  REQUIRE(automatic.block_slips.size() >= 3);
  CHECK(automatic.average_auto);
  CHECK(automatic.average_from >= automatic.block_slips.front().onset);
  CHECK(std::any_of(automatic.block_slips.begin(), automatic.block_slips.end(),
                    [&](const BlockSlip& b) { return b.onset == automatic.average_from; }));
  REQUIRE(automatic.regime);
  CHECK(automatic.regime->kind == Regime::stick_slip);
  const TraceTable friction = read_run_table(dir.path / "auto", "friction");
  const auto impulse = friction.column("impulse");
  const auto row = static_cast<std::size_t>(
      std::lower_bound(friction.t.begin(), friction.t.end(), automatic.average_from * (1 - 1e-12)) -
      friction.t.begin());
  REQUIRE(row < friction.t.size());
  REQUIRE(friction.t[row] == Approx(automatic.average_from).epsilon(1e-12));
  CHECK(automatic.mu == Approx((impulse.back() - impulse[row]) /
                               ((c.run.t_end - automatic.average_from) * automatic.F_N))
                            .epsilon(1e-9));
  // Without "auto" the table has no impulse column: nothing is paid for it.
  CHECK_THROWS(read_run_table(dir.path / "late", "friction").column("impulse"));
}

TEST_CASE(
    "average_from = \"auto\" across a restart: the impulse column is read back, the window found "
    "the same",
    "[slow][analysis][cycles][restart]") {
  test::TempDir dir("stickslip_test_auto_restart");
  Case c = small_block_from_rest();
  c.run.t_end = 10e-3;
  c.run.average_auto = true;
  c.run.average_from = 0.0;
  c.run.checkpoint_every = 3e-3;
  const Summary full = run_case(c, {dir.path / "full", false, true});

  // Stopped once its first checkpoint (3 ms, before the first block slip) is written.
  RunOptions options{dir.path / "part", false, true};
  const auto checkpoint = dir.path / "part" / "checkpoint.bin";
  options.stop_signal = [&] { return std::filesystem::exists(checkpoint) ? SIGTERM : 0; };
  CHECK_THROWS_AS(run_case(c, options), Interrupted);
  options.stop_signal = [] { return 0; };
  options.restart = true;
  const Summary part = run_case(c, options);
  CHECK(part.average_auto);
  CHECK(part.block_slips.size() == full.block_slips.size());
  // The restart changes the steps, not the physics: the same onset, to the output interval.
  CHECK(part.average_from == Approx(full.average_from).margin(c.output.interval * 1.01));
  CHECK(part.mu == Approx(full.mu).epsilon(1e-4));
}
