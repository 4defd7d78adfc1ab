// Numerical stress suite: every integrator on regimes away from the paper's
// defaults, one factor at a time from a base case (6×6×4, coverage 0.5, seed 1,
// v = 1e-3, defaults otherwise). Each run must either
//   (a) finish: finite μ, |energy residual| ≤ kResidualPerRtol × rtol,
//       summary.json written, no more steps than [solver] max_steps; or
//   (b) stop with IntegrationError whose message names the time ("t = "),
//       with no summary.json;
// and in both cases every CSV it wrote is free of nan/inf, and it never hangs
// (every run has a max_steps cap, and a watchdog aborts the whole executable
// with the run's name if one exceeds its wall-clock limit). Every row also
// says which of (a) and (b) its method does there today, so a method that
// starts to stall, or a stop that turns into a finish, shows.
//
// "[stress]" is the cheap table run by ctest (label `stress`); "[.soak]" is the
// whole matrix, hidden from ctest and run by scripts/soak, which also writes
// the table of docs/STABILITY.md (STICKSLIP_STRESS_REPORT=file appends one
// markdown row per run). STICKSLIP_STRESS_FILTER="a|b" runs only the rows
// whose name contains a or b; a test case none of whose rows it selects
// fails, having checked nothing.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/run/run.hpp"

using namespace stickslip;
namespace fs = std::filesystem;

namespace {

// The energy-residual bound of a finished run, in units of its rtol (fixed-step
// runs, which have no rtol, are held to the default rtol 1e-6). Observed
// (docs/STABILITY.md): at rtol = 1e-6 imex |R| ≤ 3.5e-6 on every regime with a
// v-scaled atol (60×60×10: 9.2e-6), bdf ≤ 1.3e-5; at rtol = 1e-4 imex 1.2e-4.
// So |R| ≈ 0.01–10 × rtol; 100 × rtol leaves a factor ≥ 8 over the worst
// observed sound run and still flags an audit off by 1e-4 at the default.
constexpr double kResidualPerRtol = 100.0;
constexpr double kDefaultRtol = 1e-6;
// run_case itself refuses a finished run beyond the bound above (its default
// audit_bound), so a finished row is held to what sound runs show instead:
// 10 × rtol (at most 2.4 × rtol in the CI subset, 9.2 × rtol on 60×60×10 in
// the soak). An audit that degrades tenfold fails here before a user's run
// is refused for it.
constexpr double kSoundResidualPerRtol = 10.0;

// `either` is for a new row whose outcome is not known yet: run it, then
// state the outcome it has.
enum class Expect { finish, stop, either };

struct Row {
  std::string name;  // "method / regime"
  Method method = Method::imex;
  std::function<void(Case&)> regime;  // one factor changed from the base
  double t_end = 1e-3;
  double average_from = 2e-4;
  long max_steps = 200'000;
  double step = 0.0;  // fixed step (rk4), 0: adaptive
  Expect expect = Expect::either;
  double wall_limit = 300.0;  // [s] the watchdog aborts beyond this: a hang
};

Case base_case() {
  Case c;
  c.lattice = {6, 6, 4, 1e-4};
  c.interface.coverage = 0.5;
  c.interface.seed = 1;
  c.drive.velocity = 1e-3;
  return c;
}

// ---- regimes (one factor from the base) ----------------------------------
using Regime = std::pair<std::string, std::function<void(Case&)>>;

std::vector<Regime> regimes() {
  std::vector<Regime> r;
  r.push_back({"base", [](Case&) {}});
  for (double eps : {1e-3, 1e-1, 1.0}) {
    std::ostringstream name;
    name << "eps=" << eps;
    r.push_back({name.str(), [eps](Case& c) { c.interface.epsilon = eps; }});
  }
  for (double b : {0.01, 0.0}) {
    std::ostringstream name;
    name << "bulk=" << b;
    r.push_back({name.str(), [b](Case& c) { c.damping.bulk = b; }});
  }
  r.push_back({"contact_damping=0", [](Case& c) { c.damping.contact = 0.0; }});
  r.push_back({"one_contact", [](Case& c) { c.interface.contacts = {{2, 3, 4.75e-4, 0}}; }});
  r.push_back({"coverage=1", [](Case& c) { c.interface.coverage = 1.0; }});
  // atol_velocity follows the drive: rtol × 0.1 v = 1e-13 (tolerances.hpp).
  r.push_back({"v=1e-6", [](Case& c) { c.drive.velocity = 1e-6; }});
  // The same with the fixed 1e-7 = 0.1 v that was the default once: the
  // energy audit is off by ~1e2, and the run must refuse to report its μ.
  r.push_back({"v=1e-6,atol_v=1e-7", [](Case& c) {
                 c.drive.velocity = 1e-6;
                 c.solver.atol_velocity = 1e-7;
               }});
  r.push_back({"v=1", [](Case& c) { c.drive.velocity = 1.0; }});
  r.push_back({"spread=2", [](Case& c) { c.interface.spread = 2.0; }});
  return r;
}

std::function<void(Case&)> regime(const std::string& name) {
  for (auto& [n, f] : regimes())
    if (n == name) return f;
  throw std::logic_error("no regime " + name);
}

// ---- checks on what a run wrote --------------------------------------------

// Every field of every CSV in `dir`, except the `error` column of steps.csv,
// which is documented as nan for rk4 (no error estimate). Returns the
// offending "file:line: field" or nothing.
std::optional<std::string> non_finite_field(const fs::path& dir, bool allow_nan_step_error) {
  for (const char* name :
       {"friction.csv", "traces.csv", "events.csv", "steps.csv", "contacts.csv"}) {
    std::ifstream in(dir / name);
    if (!in) continue;
    std::string line;
    std::getline(in, line);  // header
    for (long n = 2; std::getline(in, line); ++n) {
      std::stringstream fields(line);
      std::string f;
      for (int col = 0; std::getline(fields, f, ','); ++col) {
        if (allow_nan_step_error && std::string(name) == "steps.csv" && col == 2) continue;
        std::string lower = f;
        for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
        bool bad = lower.find("nan") != std::string::npos || lower.find("inf") != std::string::npos;
        char* end = nullptr;
        const double v = std::strtod(f.c_str(), &end);
        if (end != f.c_str() && *end == '\0' && !std::isfinite(v)) bad = true;
        if (bad) return std::string(name) + ":" + std::to_string(n) + ": " + f;
      }
    }
  }
  return std::nullopt;
}

// Aborts the executable, naming the run, if it is not disarmed within `limit`:
// a stalled integration that the max_steps cap failed to stop.
class Watchdog {
 public:
  Watchdog(std::string name, double limit)
      : thread_([this, name = std::move(name), limit] {
          std::unique_lock lock(mutex_);
          if (!cv_.wait_for(lock, std::chrono::duration<double>(limit), [this] { return done_; })) {
            std::fprintf(stderr, "\nstress: run '%s' still running after %.0f s: hang\n",
                         name.c_str(), limit);
            std::fflush(stderr);
            std::abort();
          }
        }) {}
  ~Watchdog() {
    {
      std::lock_guard lock(mutex_);
      done_ = true;
    }
    cv_.notify_one();
    thread_.join();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

const char* getenv_or_empty(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

// Whether STICKSLIP_STRESS_FILTER ('|'-separated substrings) selects the row;
// no filter selects every row.
bool selected(const Row& row) {
  const std::string filter = getenv_or_empty("STICKSLIP_STRESS_FILTER");
  if (filter.empty()) return true;
  std::stringstream parts(filter);
  for (std::string part; std::getline(parts, part, '|');)
    if (!part.empty() && row.name.find(part) != std::string::npos) return true;
  return false;
}

// Runs one row and checks (a) or (b). Prints and (optionally) reports a table row.
void stress(const Row& row) {
  Case c = base_case();
  row.regime(c);
  // [output] steps stays off (the default): the steps of a run that stopped
  // come from its message.
  c.solver.method = row.method;
  c.solver.step = row.step;
  c.solver.max_steps = row.max_steps;
  c.run.t_end = row.t_end;
  c.run.average_from = row.average_from;
  const double rtol = row.step > 0 ? kDefaultRtol : c.solver.rtol;
  const double bound = kResidualPerRtol * rtol;

  std::string dir_name = row.name;
  for (char& ch : dir_name)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '-' && ch != '.')
      ch = '_';
  // Private to this process (a concurrent ctest or soak never shares it).
  const fs::path dir =
      fs::temp_directory_path() / ("stress-run." + std::to_string(getpid())) / dir_name;
  fs::remove_all(dir);
  RunOptions options;
  options.out_dir = dir;
  options.quiet = true;

  INFO("run " << row.name << " (t_end " << row.t_end << " s, max_steps " << row.max_steps
              << ", output in " << dir << ")");
  std::optional<Summary> result;
  std::string error;
  const auto start = std::chrono::steady_clock::now();
  {
    Watchdog watchdog(row.name, row.wall_limit);
    try {
      result = run_case(c, options);
    } catch (const IntegrationError& e) {
      error = e.what();
    }
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // Steps of a stopped run: what its message says ("after N steps"); for a
  // stop that was not a step cap: "?".
  std::string steps;
  if (result) {
    steps = std::to_string(result->solver_stats.steps);
  } else if (const auto at = error.find(" after "); at != std::string::npos) {
    steps = error.substr(at + 7, error.find(' ', at + 7) - at - 7);
  } else {
    steps = "?";
  }
  // The table row: method, regime, outcome, steps, wall, residual, μ.
  std::string outcome, residual = "–", mu = "–";
  if (result) {
    outcome = "finished";
    residual = fmt("%.2e", result->energy_residual);
    mu = fmt("%.5g", result->mu);
    if (!(std::abs(result->energy_residual) <= bound))
      outcome = "finished, **residual > " + fmt("%.0e", bound) + "**";
  } else {
    outcome = "stopped: " + error;
  }
  const auto slash = row.name.find(" / ");
  std::ostringstream md;
  md << "| " << row.name.substr(0, slash) << " | " << row.name.substr(slash + 3) << " | " << outcome
     << " | " << steps << " | " << fmt("%.1f", wall) << " | " << residual << " | " << mu << " |";
  std::cout << md.str() << std::endl;
  if (const char* report = std::getenv("STICKSLIP_STRESS_REPORT"); report && *report)
    std::ofstream(report, std::ios::app) << md.str() << '\n';

  INFO("outcome: " << outcome << "; expected: "
                   << (row.expect == Expect::finish ? "finish"
                       : row.expect == Expect::stop ? "stop"
                                                    : "either"));
  // Nothing the run wrote may hold nan or inf, whether it finished or not.
  const auto bad = non_finite_field(dir, row.method == Method::rk4);
  INFO("non-finite field: " << bad.value_or("none"));
  CHECK_FALSE(bad.has_value());
  if (result) {
    CHECK(row.expect != Expect::stop);
    CHECK(std::isfinite(result->mu));
    CHECK(std::abs(result->energy_residual) <= kSoundResidualPerRtol * rtol);
    CHECK(result->solver_stats.steps <= row.max_steps);
    CHECK(fs::exists(dir / "summary.json"));
  } else {
    CHECK(row.expect != Expect::finish);
    CHECK_THAT(error, Catch::Matchers::Contains("t = "));
    CHECK_FALSE(fs::exists(dir / "summary.json"));
    CHECK(fs::exists(dir / "friction.csv"));  // what was computed is kept
  }
  fs::remove_all(dir);
  fs::remove(dir.parent_path());  // only if empty
}

// Runs the rows the filter selects, and fails when it selects none: a filter
// that matches no row would otherwise pass having checked nothing.
void stress_all(const std::vector<Row>& rows) {
  long ran = 0;
  for (const Row& r : rows)
    if (selected(r)) {
      stress(r);
      ++ran;
    }
  INFO("STICKSLIP_STRESS_FILTER=\"" << getenv_or_empty("STICKSLIP_STRESS_FILTER")
                                    << "\" selects none of this test case's " << rows.size()
                                    << " rows");
  REQUIRE(ran > 0);
}

Row make(Method m, const std::string& regime_name, Expect expect) {
  Row r;
  r.method = m;
  r.name = std::string(to_string(m)) + " / " + regime_name;
  r.regime = regime(regime_name);
  r.expect = expect;
  return r;
}

}  // namespace

// The default (auto: dirk or bdf) on every regime over 1 ms (the loading
// phase from rest: contacts stuck, creeping), every other method on the base
// regime (and bdf on ε = 1) with caps that keep each run to a few seconds.
// imex runs at rtol 1e-4: with the absolute tolerances following rtol its
// steps in the creep fall to ~5e-9 s at the default rtol (200 000 steps do
// not reach 1 ms), which is why "auto" no longer picks it.
TEST_CASE("every method finishes or stops with a diagnostic (CI subset)", "[stress]") {
  std::vector<Row> rows;
  for (const auto& [name, f] : regimes()) {
    // auto runs bdf at v = 1e-6 and finishes within the audit's bound even
    // with atol_velocity = 0.1 v (|R| 2.5e-6).
    Row r = make(Method::automatic, name, Expect::finish);
    r.wall_limit = 120;
    rows.push_back(r);
  }
  {
    // imex at atol_velocity = 0.1 v has its audit off by ~1e2: the run must
    // stop with the audit's diagnostic instead of reporting a μ.
    Row r = make(Method::imex, "v=1e-6,atol_v=1e-7", Expect::stop);
    r.wall_limit = 120;
    rows.push_back(r);
  }
  {
    Row r = make(Method::automatic, "one_contact", Expect::finish);  // through its first slips
    r.name += ", 1.5 ms";
    r.t_end = 1.5e-3;
    r.wall_limit = 120;
    rows.push_back(r);
  }
  {
    Row r = make(Method::imex, "base", Expect::finish);
    r.name += ", rtol=1e-4";
    const auto base = r.regime;
    r.regime = [base](Case& c) {
      base(c);
      c.solver.rtol = 1e-4;
    };
    r.wall_limit = 120;
    rows.push_back(r);
  }
  for (const char* name : {"base", "eps=1"}) {
    Row r = make(Method::bdf, name, Expect::finish);
    r.wall_limit = 120;
    rows.push_back(r);
  }
  {
    // dirk stalled from rest (steps of ~1e-12 s, MODEL.md §12, as Radau did)
    // while SUNDIALS' Newton ran on the contacts' stiffness; with the exact
    // stage solves (a566598) it finishes the 1 ms in 75 steps, |R| 1.5e-6.
    // The cap stays: a stall must stop with a diagnostic, and fail this row.
    Row r = make(Method::dirk, "base", Expect::finish);
    r.max_steps = 2'000;
    r.wall_limit = 120;
    rows.push_back(r);
  }
  {
    // Stuck contacts hold it to steps of ~8e-13 s (their stiffness, MODEL.md
    // §6): the cap stops it at t = 1.7e-8 s.
    Row r = make(Method::erk, "base", Expect::stop);
    r.max_steps = 20'000;
    r.wall_limit = 120;
    rows.push_back(r);
  }
  {
    // Stuck contacts near rest are stiff up to ~1e15 1/s (MODEL.md §6): rk4
    // keeps the audit within the bound only at h ≲ 1e-13 s (at 1e-12 it is
    // off by 2e-2, at 1e-11 by ~2: docs/STABILITY.md). It finishes, |R| 1e-14.
    Row r = make(Method::rk4, "base", Expect::finish);
    r.step = 1e-13;
    r.t_end = 2e-9;
    r.average_from = 0.0;
    r.wall_limit = 120;
    rows.push_back(r);
  }
  {
    Row r = make(Method::rk4, "base", Expect::stop);  // far above it: must blow up, cleanly
    r.name += ", h = 1e-8";
    r.step = 1e-8;
    r.t_end = 1e-4;
    r.average_from = 0.0;
    r.wall_limit = 120;
    rows.push_back(r);
  }
  stress_all(rows);
}

// The whole matrix (scripts/soak, ~7 min on one core): every method on every
// regime, tolerance scaling, the 60×60×10 lattice, a long horizon. Horizons
// and caps per method (see docs/STABILITY.md): imex 5 ms (the first global
// slip is at ≈ 4.1 ms); bdf, dirk and erk 1 ms capped at 3e4, 2e3 and 5e4
// steps (dirk and erk take steps of ~1e-12 s from rest); rk4 at h = 1e-13
// over 5 ns.
//
// Each row's outcome is the one it had in the soak of this file's commit (3.8
// min on one core, code 5b09bd7): the table of docs/STABILITY.md then, except
// that dirk and bdf now solve their stages exactly (a566598), so dirk
// finishes where it stalled and bdf where it hit its cap. Two rows finish
// beyond the audit bound and fail the soak (dirk at v = 1e-6: R = −1.5e-4,
// and −8 with atol_velocity 1e-7): findings, as STABILITY.md's bold rows,
// whose run_case does not judge a residual below one absolute energy
// tolerance (the work of 1 ms at v = 1e-6 is below it).
TEST_CASE("soak: every method on every regime", "[.soak]") {
  std::vector<Row> rows;
  auto custom = [](Method m, const std::string& name, std::function<void(Case&)> f, Expect expect) {
    Row r = make(m, "base", expect);
    r.name += name;
    r.regime = std::move(f);
    return r;
  };
  // imex finishes everywhere but where atol_velocity = 0.1 v leaves the
  // audit off by ~37 (refused, as in the CI subset).
  for (const auto& [name, f] : regimes()) {
    Row r = make(Method::imex, name, name == "v=1e-6,atol_v=1e-7" ? Expect::stop : Expect::finish);
    r.t_end = 5e-3;
    r.average_from = 1e-3;
    rows.push_back(r);
  }
  // bdf stalled on some regimes at ~0.5 ms per step: 1 ms, capped at 3e4
  // steps. It now finishes everywhere (33–11 087 steps, |R| ≤ 1.9e-5).
  for (const auto& [name, f] : regimes()) {
    Row r = make(Method::bdf, name, Expect::finish);
    r.max_steps = 30'000;
    rows.push_back(r);
  }
  // The bound scales with rtol: the residual should too (atol follows rtol).
  // At rtol 1e-8 the 5 ms need more than the 2e5 steps (the cap stops it
  // at 4.2 ms); 1e-4 finishes with R = 8e-5.
  for (double rtol : {1e-4, 1e-8}) {
    std::ostringstream name;
    name << ", rtol=" << rtol;
    Row r = custom(
        Method::imex, name.str(),
        [rtol](Case& c) {
          c.solver.rtol = rtol;  // the absolute tolerances follow it
        },
        rtol < 1e-6 ? Expect::stop : Expect::finish);
    r.t_end = 5e-3;
    r.average_from = 1e-3;
    rows.push_back(r);
  }
  // dirk finishes (17–1818 steps) but at ε = 0.1 and 1, where its audit is
  // off by 1.4e-4 and 1.4e-3 against the bound 1e-4 and the run is refused.
  // (ε = 0.1 is only 1.4 times over: a change of step sequence may bring it
  // under, and this row should then be looked at, not loosened.)
  for (const auto& [name, f] : regimes()) {
    Row r = make(Method::dirk, name,
                 name == "eps=0.1" || name == "eps=1" ? Expect::stop : Expect::finish);
    r.max_steps = 2'000;
    rows.push_back(r);
  }
  {
    Row r = custom(
        Method::dirk, ", order 2", [](Case& c) { c.solver.order = 2; }, Expect::finish);
    r.max_steps = 2'000;
    rows.push_back(r);
  }
  // erk is held to steps of 7e-15–7e-12 s everywhere and stops at its cap;
  // without bulk damping the error test gives up at 2.1e-7 s.
  for (const auto& [name, f] : regimes()) {
    Row r = make(Method::erk, name, Expect::stop);
    r.max_steps = 50'000;
    rows.push_back(r);
  }
  // rk4 at 1e-13 s keeps the audit exact (|R| ≤ 6e-11) but where the
  // contacts are stiffer: ε = 0.1 and 1 (R = 0.11, 167) and spread = 2 (the
  // slowest v* 1e-5 m/s, R = 1.6e-3), refused.
  for (const auto& [name, f] : regimes()) {
    const bool stiffer = name == "eps=0.1" || name == "eps=1" || name == "spread=2";
    Row r = make(Method::rk4, name, stiffer ? Expect::stop : Expect::finish);
    r.step = 1e-13;
    r.t_end = 5e-9;  // 5e4 steps
    r.average_from = 0.0;
    rows.push_back(r);
  }
  for (double h : {1e-12, 1e-11}) {
    std::ostringstream name;
    name << ", h = " << h;
    // R = 2.5e-2 and 1.2: refused.
    Row r = custom(
        Method::rk4, name.str(), [](Case&) {}, Expect::stop);
    r.step = h;
    r.t_end = 5e4 * h;  // 5e4 steps
    r.average_from = 0.0;
    rows.push_back(r);
  }
  {
    // ~45 ms per step (2.2e5 unknowns, 1800 contacts): capped at 5e3 steps.
    Row r = custom(
        Method::imex, ", 60x60x10",
        [](Case& c) {
          c.lattice = {60, 60, 10, 1e-4};
        },
        Expect::finish);
    r.t_end = 2e-4;
    r.average_from = 0.0;
    r.max_steps = 5'000;
    r.wall_limit = 600;
    rows.push_back(r);
  }
  {
    Row r = custom(
        Method::imex, ", 30 ms", [](Case&) {}, Expect::finish);
    r.t_end = 3e-2;
    r.average_from = 5e-3;
    r.wall_limit = 900;
    rows.push_back(r);
  }
  stress_all(rows);
}
