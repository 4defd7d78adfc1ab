// Micro-benchmarks (Google Benchmark) of the kernels an integration spends its
// time in, reported as lattice nodes per second ("items_per_second"):
//   rhs            the full right-hand side (erk, rk4, dirk, bdf)
//   rhs_explicit   the lattice part of imex (elastic forces, drive, damping)
//   rhs_explicit_threads   the same with [solver] threads = 1, 2 (wall time)
//   stage_solve    imex's exact per-contact implicit stage solve
//   jacobian       refreshing the sparse Jacobian's values (contact blocks only)
//   lattice_factorize      LatticeSolver::set_gamma: M(γ) per Fourier mode and the
//                          bottom layer's Green's function (dirk, bdf: once per γ)
//   lattice_solve          one FFT solve with M(γ) (one per implicit stage)
//   implicit_stage/N/P     LatticeStageSolver::solve, a whole dirk or bdf stage, at
//                          coverage P % (the contacts' coupled Newton grows with N_c);
//                          the same stage again and again, at one γ
//   machine_compute_threads/T   a floating-point loop on each of T threads at once:
//                          what T threads of this machine can give at best
//   rhs_threads/N/T, implicit_stage_threads/N/P/T   rhs and implicit_stage on T
//                          threads ([solver] threads; wall time): the speedup of
//                          one run's kernels, 120×120×10 included
//   window_analysis/N      the end-of-run analysis of F_f over N block cycles
//   dirk_stage/N/P         a stage in situ: dirk (rtol 1e-6) advanced 20 µs from the
//                          fixture's state; `rhs_per_stage` is the wall time per
//                          implicit stage in units of one rhs, timed in the same run
// on 15×15×10, 30×30×10 and 60×60×10 lattices at coverage 0.5 (unless given),
// in a state taken from a short integration from rest (contacts stuck and creeping).
//     build/bench/stickslip_micro [--benchmark_filter=rhs]
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>

#include "stickslip/case/placement.hpp"
#include "stickslip/core/cycles.hpp"
#include "stickslip/integrate/lattice_solver.hpp"
#include "stickslip/integrate/lattice_stage_solver.hpp"
#include "stickslip/integrate/make_integrator.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/model/system.hpp"

namespace {

using namespace stickslip;

struct Fixture {
  Case c;
  std::unique_ptr<System> system;
  std::vector<double> y, ydot;
};

// One system per lattice size, advanced 2 µs from rest so velocities are not zero.
Fixture& fixture(int n, double coverage = 0.5) {
  static std::map<std::pair<int, double>, std::unique_ptr<Fixture>> cache;
  auto& f = cache[{n, coverage}];
  if (!f) {
    f = std::make_unique<Fixture>();
    f->c.lattice = {n, n, 10, 1e-4};
    f->c.interface.coverage = coverage;
    f->c.solver.threads = 1;  // the kernels on one core; *_threads vary it
    f->system = std::make_unique<System>(f->c, place_contacts(f->c.lattice, f->c.interface));
    f->y.resize(static_cast<std::size_t>(f->system->size()));
    f->ydot.resize(f->y.size());
    f->system->initial_state(InitialState::rest, f->y);
    const std::vector<double> y0 = f->y;
    make_integrator(*f->system, f->c.solver, y0, 2e-6, {})->advance(2e-6, f->y);
  }
  return *f;
}

void report_nodes(benchmark::State& state, const System& s) {
  state.SetItemsProcessed(state.iterations() * s.num_nodes());
  state.counters["nodes"] = static_cast<double>(s.num_nodes());
}

void BM_rhs(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    f.system->rhs(0.0, f.y, f.ydot);
    benchmark::DoNotOptimize(f.ydot.data());
  }
  report_nodes(state, *f.system);
}

void BM_rhs_explicit(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    f.system->rhs_explicit(0.0, f.y, f.ydot);
    benchmark::DoNotOptimize(f.ydot.data());
  }
  report_nodes(state, *f.system);
}

void BM_stage_solve(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)));
  std::vector<double> z = f.y;
  for (auto _ : state) {
    std::copy(f.y.begin(), f.y.end(), z.begin());  // b, the state itself as a stand-in
    benchmark::DoNotOptimize(f.system->contact_set().solve_implicit_stage(1e-8, f.y, z));
  }
  report_nodes(state, *f.system);
}

void BM_jacobian(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)));
  SparseJacobian jac = f.system->jacobian_pattern(JacobianPart::full);
  for (auto _ : state) {
    f.system->jacobian_values(f.y, jac);
    benchmark::DoNotOptimize(jac.value.data());
  }
  report_nodes(state, *f.system);
}

// The lattice part with [solver] threads = range(1): wall time per call (the
// CPU time counts every thread).
void BM_rhs_explicit_threads(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)));
  const System& system = *f.system;
  const int threads = static_cast<int>(state.range(1));
  for (auto _ : state) {
    system.rhs_explicit(0.0, f.y, f.ydot, threads);
    benchmark::DoNotOptimize(f.ydot.data());
  }
  report_nodes(state, system);
}

// At θ = 0.04: the rhs's cost is the lattice's, and the fixture at 120×120
// stays cheap to make.
void BM_rhs_threads(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)), 0.04);
  const System& system = *f.system;
  const int threads = static_cast<int>(state.range(1));
  for (auto _ : state) {
    system.rhs(0.0, f.y, f.ydot, threads);
    benchmark::DoNotOptimize(f.ydot.data());
  }
  report_nodes(state, system);
}

// The machine's ceiling: the same floating-point loop (no memory traffic)
// on each of range(0) threads at once. With n real cores the wall time per
// iteration stays that of one thread; the ratio is what n threads can give
// any compute-bound kernel here.
void BM_machine_compute_threads(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    double total = 0.0;
#pragma omp parallel num_threads(threads) reduction(+ : total)
    {
      double s = 0.0;
      for (long i = 1; i < 20'000'000; ++i) s += std::sqrt(static_cast<double>(i));
      total += s;
    }
    benchmark::DoNotOptimize(total);
  }
  state.SetItemsProcessed(state.iterations() * threads);
}

}  // namespace

void BM_lattice_factorize(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)));
  LatticeSolver solver(*f.system);
  double gamma = 1e-7;
  for (auto _ : state) {
    gamma *= 1.0001;  // a new γ each time, as every adaptive step brings
    solver.set_gamma(gamma);
  }
  report_nodes(state, *f.system);
}

void BM_lattice_solve(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)));
  LatticeSolver solver(*f.system);
  solver.set_gamma(1e-7);
  const auto n3 = static_cast<std::size_t>(3 * f.system->num_nodes());
  std::vector<double> w(f.y.begin() + n3, f.y.begin() + 2 * n3);
  for (auto _ : state) {
    solver.solve(w, w);
    benchmark::DoNotOptimize(w.data());
  }
  report_nodes(state, *f.system);
}

void BM_implicit_stage(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)), static_cast<double>(state.range(1)) / 100);
  // The solve's cost whatever γ λ it leaves (a run would refuse such a stage).
  LatticeStageSolver solver(*f.system, std::numeric_limits<double>::infinity());
  std::vector<double> z = f.y, weights(f.y.size());
  for (std::size_t i = 0; i < z.size(); ++i) weights[i] = 1.0 / (1e-6 * std::abs(f.y[i]) + 1e-9);
  long iterations = 0;
  for (auto _ : state) {
    std::copy(f.y.begin(), f.y.end(), z.begin());  // b, the state itself as a stand-in
    iterations += solver.solve(0.0, 1e-7, f.y, weights, z);
  }
  state.counters["newton_per_stage"] =
      static_cast<double>(iterations) / static_cast<double>(state.iterations());
  state.counters["contacts"] = static_cast<double>(f.system->contact_set().contacts().size());
  report_nodes(state, *f.system);
}

// As implicit_stage, on range(2) threads; the Newton matrix's LU is made
// before the timing starts (its cost: implicit_stage's first call).
void BM_implicit_stage_threads(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)), static_cast<double>(state.range(1)) / 100);
  const System& system = *f.system;
  LatticeStageSolver solver(system, std::numeric_limits<double>::infinity(),
                            LatticeStageSolver::ContactNewton::by_count,
                            std::make_shared<const ThreadBudget>(static_cast<int>(state.range(2))));
  std::vector<double> z = f.y, weights(f.y.size());
  for (std::size_t i = 0; i < z.size(); ++i) weights[i] = 1.0 / (1e-6 * std::abs(f.y[i]) + 1e-9);
  solver.solve(0.0, 1e-7, f.y, weights, z);
  long iterations = 0;
  for (auto _ : state) {
    std::copy(f.y.begin(), f.y.end(), z.begin());
    iterations += solver.solve(0.0, 1e-7, f.y, weights, z);
  }
  state.counters["newton_per_stage"] =
      static_cast<double>(iterations) / static_cast<double>(state.iterations());
  state.counters["contacts"] = static_cast<double>(system.contact_set().contacts().size());
  report_nodes(state, system);
}

void BM_dirk_stage(benchmark::State& state) {
  auto& f = fixture(static_cast<int>(state.range(0)), static_cast<double>(state.range(1)) / 100);
  SolverParams solver;
  solver.method = Method::dirk;
  constexpr double kInterval = 20e-6;
  // One rhs, timed here so that the ratio comes from one run.
  constexpr int kRhs = 200;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < kRhs; ++k) {
    f.system->rhs(0.0, f.y, f.ydot);
    benchmark::DoNotOptimize(f.ydot.data());
  }
  const double rhs_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / kRhs;
  long stages = 0, steps = 0, factorizations = 0;
  double seconds = 0.0;
  std::vector<double> y = f.y;
  for (auto _ : state) {
    y = f.y;
    // Timed from after the set-up (the lattice solver's probes, ARKStep).
    const auto integrator = make_integrator(*f.system, solver, f.y, kInterval, {});
    const auto begin = std::chrono::steady_clock::now();
    integrator->advance(kInterval, y);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    const SolverStats st = integrator->stats();
    // ESDIRK436L2SA (dirk's default table) solves 5 stages per step attempt;
    // f is no longer evaluated at each (ARKStep deduces it), so rhs_implicit
    // does not count them.
    stages += 5 * st.step_attempts;
    steps += st.steps;
    factorizations += st.jacobian_evaluations;
  }
  const auto runs = static_cast<double>(state.iterations());
  state.counters["stages"] = static_cast<double>(stages) / runs;
  state.counters["steps"] = static_cast<double>(steps) / runs;
  state.counters["contact_lu"] = static_cast<double>(factorizations) / runs;
  state.counters["rhs_per_stage"] = seconds / static_cast<double>(stages) / rhs_seconds;
  state.counters["contacts"] = static_cast<double>(f.system->contact_set().contacts().size());
}

// The end-of-run analysis of F_f (core/cycles.hpp) on a sawtooth of N block
// cycles sampled 2 000 times each: finding the window's start ("auto": MSER
// over the cycles) and judging it. Its cost must stay a pass or two over the
// samples however many cycles there are (it once grew as cycles² × samples:
// 53 s at 500 cycles).
static void BM_window_analysis(benchmark::State& state) {
  const auto cycles = static_cast<long>(state.range(0));
  std::vector<double> t, f;
  for (long k = 0; k < cycles * 2000; ++k) {
    t.push_back(static_cast<double>(k) * 1e-7);
    f.push_back(2.0 + 4.0 * static_cast<double>(k % 2000) / 2000.0 +
                1e-3 * static_cast<double>(k % 7));
  }
  for (auto _ : state) {
    const double from = stickslip::settled_from(t, f);
    benchmark::DoNotOptimize(stickslip::analyse_window(t, f, from, true));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(t.size()));
}

BENCHMARK(BM_window_analysis)->Arg(50)->Arg(500)->Unit(benchmark::kMillisecond);

BENCHMARK(BM_rhs)->Arg(15)->Arg(30)->Arg(60);
BENCHMARK(BM_lattice_factorize)->Arg(15)->Arg(30)->Arg(60);
BENCHMARK(BM_lattice_solve)->Arg(15)->Arg(30)->Arg(60);
BENCHMARK(BM_implicit_stage)
    ->Args({15, 4})
    ->Args({15, 50})
    ->Args({30, 4})
    ->Args({30, 50})
    ->Args({60, 4})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_dirk_stage)
    ->Args({15, 50})
    ->Args({30, 50})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK(BM_machine_compute_threads)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_rhs_threads)->ArgsProduct({{15, 60, 120}, {1, 2}})->UseRealTime();
BENCHMARK(BM_implicit_stage_threads)
    ->ArgsProduct({{15, 60, 120}, {4}, {1, 2}})
    ->Args({15, 50, 1})
    ->Args({15, 50, 2})
    ->Args({60, 50, 1})
    ->Args({60, 50, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_rhs_explicit_threads)
    ->ArgsProduct({{15, 30, 60}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_rhs_explicit)->Arg(15)->Arg(30)->Arg(60);
BENCHMARK(BM_stage_solve)->Arg(15)->Arg(30)->Arg(60);
BENCHMARK(BM_jacobian)->Arg(15)->Arg(30)->Arg(60);

BENCHMARK_MAIN();
