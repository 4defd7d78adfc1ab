// The plot scripts (plots/*.py, run with /usr/bin/python3) on tiny outputs:
// each writes a PNG and a PDF, and the numbers it says it plotted are the
// ones in the outputs it read.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "sandbox.hpp"
#include "stickslip/output/tables.hpp"
#include "test_cases.hpp"

namespace test = stickslip::test;

using stickslip::member_column;
using stickslip::read_run_columns;
using stickslip::read_run_table;
using stickslip::TraceTable;
using test::Sandbox;
using test::slurp;
namespace fs = std::filesystem;

namespace {

const char* kTwoContacts = R"([lattice]
nx = 6
ny = 6
nz = 4
[interface]
contacts = [ { site = [1, 2], v_star = 4.75e-4 }, { site = [2, 2], v_star = 2.09e-3 } ]
[run]
t_end = 3e-4
average_from = 1e-4
[output]
interval = 1e-6
traces = "all"
)";

struct Script {
  int code;
  std::string out;
};

Script python(const Sandbox& box, const std::string& script, const std::string& args) {
  const std::string cmd = "cd " + test::quote(box.work.string()) + " && /usr/bin/python3 " +
                          test::quote(std::string(STICKSLIP_SOURCE_DIR) + "/plots/" + script) +
                          " " + args + " >plot.txt 2>&1";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(box.work / "plot.txt")};
}

// A real PNG with something drawn in it (an empty figure is ~2 kB).
void check_png(const fs::path& png) {
  INFO(png);
  REQUIRE(fs::exists(png));
  const std::string bytes = slurp(png);
  CHECK(bytes.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
  CHECK(bytes.size() > 10'000);
  CHECK(fs::file_size(fs::path(png).replace_extension(".pdf")) > 1'000);
}

}  // namespace

TEST_CASE("fig7.py, fig9.py and epsilon.py plot the sweep's mean mu per coverage",
          "[slow][plots]") {
  Sandbox box("stickslip_plots_");
  box.write("base.toml", test::kTinyBaseToml);
  box.write("s.toml",
            "[sweep]\ncase = \"base.toml\"\n[vary]\ndrive.velocity = [1e-3, 2e-3]\n"
            "interface.coverage = [0.2, 0.5]\ninterface.seed = [1, 2]\n");
  box.write("e.toml",
            "[sweep]\ncase = \"base.toml\"\n[vary]\ninterface.epsilon = [1e-2, 3e-2]\n"
            "interface.coverage = [0.2, 0.5]\n");
  REQUIRE(box.run({"sweep", "s.toml", "--jobs", "2"}).code == 0);
  REQUIRE(box.run({"sweep", "e.toml", "--jobs", "2"}).code == 0);

  // The means the script prints are sweep_summary.csv's, for all four groups.
  std::map<std::pair<std::string, std::string>, double> expected;        // (v, coverage) -> μ mean
  std::map<std::pair<std::string, std::string>, std::string> untrusted;  // -> runs flagged
  {
    std::istringstream in(slurp(box.work / "out" / "s" / "sweep_summary.csv"));
    std::string line;
    std::getline(in, line);
    REQUIRE(line ==
            "drive.velocity,interface.coverage,theta_mean,mu_mean,mu_std,mu_sem,count,"
            "mu_whole_cycles_mean,mu_whole_cycles_std,mu_whole_cycles_sem,untrusted,mu_runs_error,"
            "mu_whole_cycles_runs_error");
    while (std::getline(in, line)) {
      std::vector<std::string> f;
      std::istringstream cells(line);
      for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
      // The plots show μ over whole cycles where every run has block cycles, else μ.
      expected[{f[0], f[2]}] = std::stod(f[7].empty() ? f[3] : f[7]);
      untrusted[{f[0], f[2]}] = f[10];
    }
  }
  REQUIRE(expected.size() == 4);
  for (const char* script : {"fig7.py", "fig9.py"}) {
    const auto r = python(box, script, "out/s");
    INFO(script << ": " << r.out);
    REQUIRE(r.code == 0);
    check_png(box.work / "out" / "s" / (std::string(script).substr(0, 4) + ".png"));
    // The title names the lattice the sweep ran, not the paper's.
    CHECK_THAT(r.out,
               Catch::Contains("title: Fig. " + std::string(1, script[3]) + ": μ(θ), 6×6×4\n"));
    std::istringstream lines(r.out);
    int matched = 0;
    static const std::regex printed(
        R"(v \(m/s\)=(\S+) theta=(\S+) (?:mu_whole_cycles|mu)_mean=(\S+) (?:mu_whole_cycles|mu)_std=(\S+)(?: runs_error=\S+)? n=(\d+)( UNTRUSTED in (\d+) of \d+ runs.*)?)");
    for (std::string line; std::getline(lines, line);) {
      std::smatch m;
      if (!std::regex_match(line, m, printed)) continue;
      const auto it = std::find_if(expected.begin(), expected.end(), [&](const auto& e) {
        return e.first.first == m[1].str() &&
               std::abs(std::stod(e.first.second) - std::stod(m[2].str())) < 1e-3;
      });
      REQUIRE(it != expected.end());
      CHECK(std::stod(m[3].str()) == Approx(it->second).epsilon(1e-5));
      CHECK(m[5].str() == "2");
      // A group with a run whose μ is no friction coefficient is marked, with its count.
      CHECK((m[7].matched ? m[7].str() : "0") == untrusted.at(it->first));
      ++matched;
    }
    CHECK(matched == 4);
  }
  const auto eps = python(box, "epsilon.py", "out/e");
  INFO(eps.out);
  REQUIRE(eps.code == 0);
  check_png(box.work / "out" / "e" / "epsilon.png");
  CHECK_THAT(eps.out, Catch::Contains("ε=0.01 theta=") && Catch::Contains("ε=0.03 theta="));
  // The sweep does not vary v: the title gives its points' v.
  CHECK_THAT(eps.out, Catch::Contains("title: μ(θ) for several ε, 6×6×4, v = 0.001 m/s\n"));
}

TEST_CASE("fig7.py on a sweep that varies neither v nor the lattice takes both from its points",
          "[slow][plots]") {
  Sandbox box("stickslip_plots_");
  box.write("base.toml", std::string(test::kTinyBaseToml) + "[drive]\nvelocity = 2e-3\n");
  box.write("c.toml",
            "[sweep]\ncase = \"base.toml\"\n[vary]\ninterface.coverage = [0.2, 0.5]\n"
            "interface.seed = [1, 2]\n");
  REQUIRE(box.run({"sweep", "c.toml", "--jobs", "2"}).code == 0);
  const auto r = python(box, "fig7.py", "out/c");
  INFO(r.out);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("title: Fig. 7: μ(θ), 6×6×4\n"));
  CHECK_THAT(r.out, !Catch::Contains("15×15×10"));
  // Each coverage's line names the points' v, not "-".
  std::istringstream lines(r.out);
  int with_v = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.find(" theta=") == std::string::npos) continue;
    CHECK_THAT(line, Catch::StartsWith("v (m/s)=0.002 theta="));
    CHECK_THAT(line, Catch::Contains(" n=2"));
    ++with_v;
  }
  CHECK(with_v == 2);
}

TEST_CASE("fig8.py, fig10.py, traces.py and pair_separation.py plot what the runs wrote",
          "[slow][plots]") {
  Sandbox box("stickslip_plots_");
  box.write("base.toml", test::kTinyBaseToml);
  box.write("two.toml", kTwoContacts);
  REQUIRE(box.run({"run", "base.toml", "--out", "low", "--set", "interface.coverage=0.1", "--set",
                   "drive.velocity=2e-3"})
              .code == 0);
  // One run of each pair writes HDF5: the scripts read either format.
  REQUIRE(box.run({"run", "base.toml", "--out", "high", "--set", "interface.coverage=0.5", "--set",
                   "output.format=\"hdf5\"", "--set", "drive.velocity=2e-3"})
              .code == 0);
  REQUIRE(fs::exists(box.work / "high" / "run.h5"));
  const auto f8 = python(box, "fig8.py", "low high fig8.png");
  INFO(f8.out);
  REQUIRE(f8.code == 0);
  check_png(box.work / "fig8.png");
  // The title gives the runs' lattice and v (not the paper's 1e-3).
  CHECK_THAT(f8.out,
             Catch::Contains("title: Fig. 8: friction force per coverage, 6×6×4, v = 0.002 m/s\n"));
  for (const char* dir : {"low", "high"}) {
    const auto s = nlohmann::json::parse(slurp(box.work / dir / "summary.json"));
    char expect[64];
    std::snprintf(expect, sizeof expect, "%s: theta=%.4g mu=%.6g", dir, s["theta"].get<double>(),
                  s["mu"].get<double>());
    CHECK_THAT(f8.out, Catch::Contains(expect));
  }

  REQUIRE(box.run({"run", "two.toml", "--out", "a"}).code == 0);
  REQUIRE(box.run({"run", "two.toml", "--out", "b", "--set", "output.format=\"hdf5\"", "--set",
                   "interface.contacts=[{site=[1,2],v_star=4.75e-4},{site=[4,2],v_star=2.09e-3}]"})
              .code == 0);
  const auto f10 = python(box, "fig10.py", "a b fig10.png");
  INFO(f10.out);
  REQUIRE(f10.code == 0);
  check_png(box.work / "fig10.png");
  CHECK_THAT(f10.out, Catch::Contains("(a) a: separation (1, 0) a") &&
                          Catch::Contains("(b) b: separation (3, 0) a"));
  const auto tr = python(box, "traces.py", "b");
  INFO(tr.out);
  REQUIRE(tr.code == 0);
  check_png(box.work / "b" / "traces.png");
  // One panel per traced contact, the figure 8 × (2.2 n + 0.6) inches at
  // 120 dpi (plots/traces.py): 960 × 600 pixels for the pair, as the PNG's
  // header (its IHDR chunk) gives them.
  const std::string png = slurp(box.work / "b" / "traces.png");
  REQUIRE(png.size() > 24);
  CHECK(png.substr(12, 4) == "IHDR");
  auto big_endian = [&](std::size_t at) {
    std::uint32_t value = 0;
    for (std::size_t k = 0; k < 4; ++k)
      value = value << 8 | static_cast<unsigned char>(png[at + k]);
    return value;
  };
  CHECK(big_endian(16) == 960);
  CHECK(big_endian(20) == 600);
  // Each panel shows its contact's trace as the run wrote it: every sample
  // (0.3 ms at 1e-6 s), its largest v_x as read back here, and the v* the
  // run was given; the title gives summary.json's μ and θ.
  const TraceTable traces = read_run_table(box.work / "b", "traces");
  REQUIRE(traces.t.size() == 301);
  const std::array<double, 2> v_star{4.75e-4, 2.09e-3};
  for (int id : {0, 1}) {
    const auto& vx = traces.column(member_column("vx", id));
    char expect[160];
    std::snprintf(expect, sizeof expect,
                  "contact %d: %zu samples, max vx = %.9g m/s, v* = %.9g m/s\n", id, vx.size(),
                  *std::max_element(vx.begin(), vx.end()), v_star[static_cast<std::size_t>(id)]);
    CHECK_THAT(tr.out, Catch::Contains(expect));
  }
  {
    const auto s = nlohmann::json::parse(slurp(box.work / "b" / "summary.json"));
    char expect[96];
    std::snprintf(expect, sizeof expect, "title: μ = %.4f, θ = %.4g\n", s["mu"].get<double>(),
                  s["theta"].get<double>());
    CHECK_THAT(tr.out, Catch::Contains(expect));
  }

  box.write("pairs.toml",
            "[sweep]\ncase = \"two.toml\"\n[vary.interface.contacts]\n"
            "x1 = [{site=[1,2],v_star=4.75e-4},{site=[2,2],v_star=2.09e-3}]\n"
            "diag2 = [{site=[1,2],v_star=4.75e-4},{site=[3,4],v_star=2.09e-3}]\n");
  REQUIRE(box.run({"sweep", "pairs.toml", "--jobs", "2"}).code == 0);
  const auto ps = python(box, "pair_separation.py", "out/pairs");
  INFO(ps.out);
  REQUIRE(ps.code == 0);
  check_png(box.work / "out" / "pairs" / "pair_separation.png");
  CHECK_THAT(ps.out, Catch::Contains("x        separation 1 a") &&
                         Catch::Contains("diagonal separation 2.83 a"));
}

// [slow]: 26 Python start-ups, ~1 min on two busy cores.
TEST_CASE(
    "every plot script and example answers --help with its usage, a missing directory with "
    "not found",
    "[slow][plots]") {
  Sandbox box("stickslip_plots_");
  // Each script with as many directories as it needs, all missing.
  const std::vector<std::pair<std::string, std::string>> scripts{
      {"block_slip_map.py", "nowhere"}, {"block_slips.py", "nowhere"},
      {"cost_scaling.py", "nowhere"},   {"epsilon.py", "nowhere"},
      {"fig7.py", "nowhere"},           {"fig8.py", "nowhere nowhere2"},
      {"fig9.py", "nowhere"},           {"fig10.py", "nowhere nowhere2"},
      {"finite_size.py", "nowhere"},    {"pair_separation.py", "nowhere"},
      {"patch_size.py", "nowhere"},     {"spectra.py", "nowhere"},
      {"traces.py", "nowhere"},         {"work_precision.py", "nowhere"}};
  // No script in plots/ is left out (the modules' names begin with '_', and run_tables.py).
  std::size_t listed = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(STICKSLIP_SOURCE_DIR) / "plots")) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() != ".py" || name[0] == '_' || name == "run_tables.py") continue;
    INFO(name);
    CHECK(std::count_if(scripts.begin(), scripts.end(),
                        [&](const auto& s) { return s.first == name; }) == 1);
    // Runnable by its path: a shebang for /usr/bin/python3 and the run bit.
    CHECK(slurp(entry.path()).rfind("#!/usr/bin/python3\n", 0) == 0);
    CHECK((fs::status(entry.path()).permissions() & fs::perms::owner_exec) != fs::perms::none);
    ++listed;
  }
  CHECK(listed == scripts.size());
  for (const auto& [script, dirs] : scripts) {
    INFO(script);
    const auto help = python(box, script, "--help");
    INFO("--help: " << help.out);
    CHECK(help.code == 0);
    // Its usage line, naming the script.
    CHECK_THAT(help.out,
               Catch::Contains("usage", Catch::CaseSensitive::No) && Catch::Contains(script));
    CHECK_THAT(help.out, !Catch::Contains("error:"));
    const auto missing = python(box, script, dirs);
    INFO(missing.out);
    CHECK(missing.code == 2);
    CHECK_THAT(missing.out, Catch::Contains("error: nowhere: not found"));
    // Nothing written but the captured output (plot.txt).
    CHECK(std::distance(fs::directory_iterator(box.work), fs::directory_iterator()) == 1);
  }
  // The examples too: runnable, and --help prints their usage without running anything.
  std::size_t examples = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(STICKSLIP_SOURCE_DIR) / "examples")) {
    if (entry.path().extension() != ".py") continue;
    const std::string name = entry.path().filename().string();
    INFO(name);
    CHECK(slurp(entry.path()).rfind("#!/usr/bin/python3\n", 0) == 0);
    CHECK((fs::status(entry.path()).permissions() & fs::perms::owner_exec) != fs::perms::none);
    const std::string cmd = "cd " + test::quote(box.work.string()) + " && " +
                            test::quote(entry.path().string()) + " --help >help.txt 2>&1";
    const int status = std::system(cmd.c_str());
    const std::string help = slurp(box.work / "help.txt");
    INFO(help);
    CHECK((WIFEXITED(status) && WEXITSTATUS(status) == 0));
    CHECK_THAT(help, Catch::Contains("Usage: ") && Catch::Contains("examples/" + name));
    fs::remove(box.work / "help.txt");
    CHECK(std::distance(fs::directory_iterator(box.work), fs::directory_iterator()) == 1);
    ++examples;
  }
  CHECK(examples == 2);
}

TEST_CASE("run_tables.py reads the same tables from a run's CSV files and from its run.h5",
          "[slow][plots]") {
  Sandbox box("stickslip_plots_tables_");
  // 1 ms: the first slips come at ~0.7 ms.
  box.write("two.toml", std::string(kTwoContacts) + "signals = true\nsteps = true\n");
  REQUIRE(box.run({"run", "two.toml", "--out", "csv", "--set", "run.t_end=1e-3"}).code == 0);
  REQUIRE(box.run({"run", "two.toml", "--out", "hdf5", "--set", "run.t_end=1e-3", "--set",
                   "output.format=\"hdf5\""})
              .code == 0);
  // h5py reads the file: a second reader, not the code's own.
  box.write("same.py", R"(import sys
import numpy as np
from run_tables import read_table
for name in ["contacts", "friction", "traces", "events", "steps", "signals"]:
    a, b = read_table("csv", name), read_table("hdf5", name)
    assert a is not None and b is not None, name
    assert sorted(a) == sorted(b), (name, sorted(a), sorted(b))
    for column in a:
        x, y = a[column], b[column]
        assert len(x) == len(y) and len(x) > 1, (name, column)
        if x.dtype.kind in "fi":
            ok = np.isclose(x, y, rtol=5.0001e-10, atol=0, equal_nan=True)
            assert ok.all(), (name, column)
        else:
            assert (x == y).all(), (name, column)
    print(name, len(a["t" if "t" in a else "id"]), "rows,", len(a), "columns: the same")
assert read_table("csv", "final_state") is None and read_table("hdf5", "final_state") is None
)");
  const std::string cmd = "cd " + test::quote(box.work.string()) + " && PYTHONPATH=" +
                          test::quote(std::string(STICKSLIP_SOURCE_DIR) + "/plots") +
                          " /usr/bin/python3 same.py >same.txt 2>&1";
  const int status = std::system(cmd.c_str());
  const std::string out = slurp(box.work / "same.txt");
  INFO(out);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  CHECK_THAT(out, Catch::Contains("events") && Catch::Contains("signals 1001 rows"));
}

TEST_CASE("work_precision.py tabulates the least time per error level and the default's ratios",
          "[plots][work_precision]") {
  Sandbox box("stickslip_plots_");
  // A hand-made table: two adaptive settings, two fixed steps, an rk4 run
  // stopped at a timeout.
  const std::string header =
      "method,setting,status,wall_seconds,peak_rss_kb,steps,rhs_explicit,rhs_implicit,"
      "energy_residual,mu,mu_error,trace_error,event_error,unmatched_events,state_error,"
      "state_wall_seconds,t_reached,extrapolated_wall_seconds,message\n";
  fs::create_directories(box.work / "wp");
  box.write("wp/work_precision.csv",
            header +
                "imex,rtol=1e-05,finished,2,1,1,1,1,0,5,3e-3,1e-2,1e-6,0,1e-4,1,,,\n"
                "imex,rtol=1e-06,finished,4,1,1,1,1,0,5,-2e-5,1e-3,1e-7,0,1e-5,1,,,\n"
                "imex-fixed,step=1e-07,finished,30,1,1,1,1,0,5,5e-4,1e-2,1e-6,0,1e-4,1,,,\n"
                "imex-fixed,step=1e-08,finished,90,1,1,1,1,0,5,1e-5,1e-3,1e-7,0,1e-5,1,,,\n"
                "rk4,step=1e-13,timeout,120,1,,,,,,,,,,,,1e-7,1.8e6,stopped after 120 s\n");
  const auto r = python(box, "work_precision.py", "wp");
  INFO(r.out);
  REQUIRE(r.code == 0);
  check_png(box.work / "wp" / "work_precision.png");
  const std::string table = slurp(box.work / "wp" / "best_times.md");
  INFO(table);
  // μ error levels 1e-2 … 1e-8: imex reaches 1e-2 in 2 s (3e-3), 1e-3 and
  // 1e-4 in 4 s, not 1e-5 (|−2e-5| > 1e-5); fixed 1e-2 and 1e-3 in 30 s
  // (5e-4), 1e-4 and 1e-5 in 90 s (1e-5).
  CHECK_THAT(table, Catch::Contains("| imex | 2 s | 4 s | 4 s | – | – | – | – |"));
  CHECK_THAT(table, Catch::Contains("| imex-fixed | 30 s | 30 s | 90 s | 90 s | – | – | – |"));
  // At the default's μ error (2e-5) the cheapest fixed step as accurate is
  // 1e-8 (90 s): 22.5 times the default's 4 s; rk4 at least 1.8e6 / 4.
  CHECK_THAT(table, Catch::Contains("step=1e-08, 90 s → ratio 22.5"));
  CHECK_THAT(table, Catch::Contains("ratio ≥ 4.5e+05"));
}

namespace {

// spectrum.csv's columns f, psd_block_velocity, psd_acoustic.
std::vector<std::array<double, 3>> spectrum(const fs::path& csv) {
  std::istringstream in(slurp(csv));
  std::string line;
  std::getline(in, line);
  REQUIRE(line == "f,psd_block_velocity,psd_acoustic");
  std::vector<std::array<double, 3>> rows;
  while (std::getline(in, line)) {
    std::array<double, 3> r{};
    REQUIRE(std::sscanf(line.c_str(), "%lf,%lf,%lf", &r[0], &r[1], &r[2]) == 3);
    rows.push_back(r);
  }
  return rows;
}

}  // namespace

TEST_CASE("spectra.py: a sine's line at its frequency with its power (Parseval)",
          "[plots][spectra]") {
  Sandbox box("stickslip_plots_");
  // 0.1 s sampled every 10 µs; the block velocity a sine of 1.25 kHz and
  // amplitude 2e-3 m/s on an offset, the acoustic signal one of 7.5 kHz, 3 N/s.
  std::ostringstream csv;
  csv << "t,block_velocity,contact_impulse,acoustic\n";
  for (int k = 0; k <= 10000; ++k) {
    const double t = k * 1e-5;
    char row[160];
    std::snprintf(row, sizeof row, "%.12g,%.17g,0,%.17g\n", t,
                  1e-3 + 2e-3 * std::sin(2 * M_PI * 1250 * t),
                  k < 2 ? NAN : 3.0 * std::cos(2 * M_PI * 7500 * t));
    csv << row;
  }
  fs::create_directories(box.work / "run");
  box.write("run/signals.csv", csv.str());
  box.write("run/summary.json", R"({"theta": 0.1, "average_from": 0.0, "t_end": 0.1})");
  fs::create_directories(box.work / "elsewhere");
  const auto missing = python(box, "spectra.py", "elsewhere");
  CHECK(missing.code == 2);
  CHECK_THAT(missing.out, Catch::Contains("elsewhere/signals.csv: not found") &&
                              Catch::Contains("signals = true"));
  const auto r = python(box, "spectra.py", "run --segment 0.008");
  INFO(r.out);
  REQUIRE(r.code == 0);
  check_png(box.work / "run" / "spectrum.png");
  const auto rows = spectrum(box.work / "run" / "spectrum.csv");
  const double df = rows[1][0] - rows[0][0];
  CHECK(df == Approx(125.0));  // 1 / 8 ms
  for (int column : {1, 2}) {
    const double line = column == 1 ? 1250 : 7500, variance = column == 1 ? 2e-6 : 4.5;
    std::size_t peak = 0;
    double power = 0;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (rows[i][column] > rows[peak][column]) peak = i;
      power += rows[i][column] * df;
    }
    INFO("column " << column);
    CHECK(rows[peak][0] == Approx(line));
    CHECK(power == Approx(variance).epsilon(0.01));  // the offset removed, A²/2 left
  }
}

TEST_CASE(
    "spectra.py on the Fig. 10b pair: lines at contact 0's slip rate, the block's "
    "resonance",
    "[slow][plots][spectra]") {
  Sandbox box("stickslip_plots_");
  const auto run = box.run({"run", std::string(STICKSLIP_SOURCE_DIR) + "/cases/fig10b.toml",
                            "--out", "pair", "--set", "output.signals=true", "--quiet"});
  INFO(run.out << run.err);
  REQUIRE(run.code == 0);
  const auto summary = nlohmann::json::parse(slurp(box.work / "pair" / "summary.json"));
  const double recurrence =
      summary["events"]["per_contact"][0]["mean_recurrence"].get<double>();  // ~0.28 ms
  // One periodogram over the 2 ms window: 500 Hz bins.
  const auto r = python(box, "spectra.py", "pair --segment 2e-3");
  INFO(r.out);
  REQUIRE(r.code == 0);
  const auto rows = spectrum(box.work / "pair" / "spectrum.csv");
  const double df = rows[1][0];
  REQUIRE(df == Approx(500.0));
  const auto nearest = static_cast<std::size_t>(std::lround(1 / recurrence / df));
  for (int column : {1, 2}) {
    INFO("column " << column << ", slip rate " << 1 / recurrence << " Hz");
    // The lowest line is the slip rate: a local maximum at its bin, 100× above
    // everything below 3/4 of it.
    CHECK(rows[nearest][column] > rows[nearest - 1][column]);
    CHECK(rows[nearest][column] > rows[nearest + 1][column]);
    for (std::size_t i = 0; rows[i][0] < 0.75 / recurrence; ++i)
      CHECK(rows[nearest][column] > 100 * rows[i][column]);
  }
  // The block velocity's strongest line is the block's own quarter-wave shear
  // resonance, rung by every slip: held at the top by the drive springs,
  // nearly free at the bottom, f = c_t / (4 Nz a) = 14.4 kHz (c_t = 57.7 m/s).
  std::size_t peak = 1;
  for (std::size_t i = 1; i < rows.size(); ++i)
    if (rows[i][1] > rows[peak][1]) peak = i;
  CHECK(rows[peak][0] == Approx(57.735 / (4 * 10 * 1e-4)).epsilon(0.1));
}

TEST_CASE("patch_size.py: mu and F_f's spread per patch size and coverage, means over seeds",
          "[slow][plots]") {
  Sandbox box("stickslip_plots_");
  box.write("base.toml", test::kTinyBaseToml);
  box.write("p.toml",
            "[sweep]\ncase = \"base.toml\"\n[vary]\ninterface.coverage = [0.2, 0.5]\n"
            "interface.seed = [1, 2]\n[[vary.together]]\nlattice.nx = [6, 8]\n"
            "lattice.ny = [6, 8]\ninterface.patch = [1, 2]\n");
  const auto missing = python(box, "patch_size.py", "out/p");
  CHECK(missing.code == 2);
  CHECK_THAT(missing.out, Catch::Contains("out/p: not found"));
  fs::create_directories(box.work / "out" / "p");
  const auto no_table = python(box, "patch_size.py", "out/p");
  CHECK(no_table.code == 2);
  CHECK_THAT(no_table.out, Catch::Contains("out/p/sweep.csv: not found"));
  fs::remove(box.work / "out" / "p");
  REQUIRE(box.run({"sweep", "p.toml", "--jobs", "2"}).code == 0);

  // Expected: from every point's summary.json, grouped by (R, coverage).
  std::map<std::pair<int, double>, std::vector<double>> mu, spread;
  for (const auto& entry : fs::directory_iterator(box.work / "out" / "p")) {
    if (!entry.is_directory()) continue;
    const auto s = nlohmann::json::parse(slurp(entry.path() / "summary.json"));
    const std::pair<int, double> key{s["case"]["interface"]["patch"].get<int>(),
                                     s["case"]["interface"]["coverage"].get<double>()};
    mu[key].push_back(s["mu_whole_cycles"].is_object() ? s["mu_whole_cycles"]["mu"].get<double>()
                                                       : s["mu"].get<double>());
    spread[key].push_back(s["F_f_spread"].get<double>());
  }
  REQUIRE(mu.size() == 4);
  const auto mean = [](const std::vector<double>& v) {
    REQUIRE(v.size() == 2);
    return (v[0] + v[1]) / 2;
  };

  const auto r = python(box, "patch_size.py", "out/p");
  INFO(r.out);
  REQUIRE(r.code == 0);
  check_png(box.work / "out" / "p" / "patch_size.png");
  static const std::regex group(
      R"(R=(\d) coverage=(\S+) theta=\S+ n=(\d) mu_mean=(\S+) mu_sd=\S+ spread_mean=(\S+) .*)");
  static const std::regex dropped(R"(R=(\d) drop=(\S+) drop_sd=\S+)");
  int groups = 0, drops = 0;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (std::regex_match(line, m, group)) {
      const std::pair<int, double> key{std::stoi(m[1].str()), std::stod(m[2].str())};
      REQUIRE(mu.count(key) == 1);
      CHECK(m[3].str() == "2");
      CHECK(std::stod(m[4].str()) == Approx(mean(mu[key])).epsilon(1e-5));
      CHECK(std::stod(m[5].str()) == Approx(mean(spread[key])).epsilon(1e-3));
      ++groups;
    } else if (std::regex_match(line, m, dropped)) {
      const int patch = std::stoi(m[1].str());
      const double low = mean(mu[{patch, 0.2}]), high = mean(mu[{patch, 0.5}]);
      CHECK(std::stod(m[2].str()) == Approx((low - high) / low).margin(1e-3));
      ++drops;
    }
  }
  CHECK(groups == 4);
  CHECK(drops == 2);
  CHECK(fs::exists(box.work / "out" / "p" / "patch_size.csv"));
}

namespace {

// finite_size.py's input: seeds whose μ are known. At θ = 0.04 the mean is 5,
// at θ = 0.498 it is 5 (1 − drop(L)) with drop(L) = 0.1 + 0.6/L, exactly
// linear in 1/L, so any weighted straight line meets 0.1 at L → ∞. Seed k
// lies 0.05 (k − 2) from the mean: sd 0.05 over seeds 1–3, seed 2 on it.
double finite_size_drop(int width) {
  return 0.1 + 0.6 / width;
}

void write_finite_size_points(const fs::path& dir, const std::vector<int>& seeds_60_wide_low,
                              double (*drop)(int) = finite_size_drop) {
  for (int width : {15, 30, 60})
    for (double coverage : {0.04, 0.498})
      for (int seed : {1, 2, 3}) {
        if (width == 60 && coverage < 0.1 &&
            std::find(seeds_60_wide_low.begin(), seeds_60_wide_low.end(), seed) ==
                seeds_60_wide_low.end())
          continue;
        const double mean = coverage < 0.1 ? 5.0 : 5.0 * (1 - drop(width));
        const double mu = mean + 0.05 * (seed - 2);
        const nlohmann::json summary = {
            {"case",
             {{"lattice", {{"nx", width}, {"ny", width}, {"nz", 10}}},
              {"interface", {{"coverage", coverage}, {"seed", seed}}}}},
            {"mu", mu + 1.0},  // the window mean: not the one to use
            {"mu_whole_cycles", {{"mu", mu}, {"from", 0.025}, {"to", 0.065}, {"crossings", 5}}},
            {"F_f_spread", 0.1},
            {"wall_seconds", 3600.0},
            {"contacts", 100}};
        const fs::path point =
            dir / ("coverage=" + std::to_string(coverage) + "_seed=" + std::to_string(seed) +
                   "_nx=" + std::to_string(width));
        fs::create_directories(point);
        std::ofstream(point / "summary.json") << summary.dump();
      }
}

}  // namespace

TEST_CASE("finite_size.py: the drop per width with its propagated error, and its extrapolation",
          "[plots]") {
  Sandbox box("stickslip_plots_");
  const auto drop = finite_size_drop;
  write_finite_size_points(box.work / "fs", {1, 2, 3});
  const auto r = python(box, "finite_size.py", "fs");
  INFO(r.out);
  REQUIRE(r.code == 0);
  check_png(box.work / "fs" / "finite_size.png");
  const double sem = 0.05 / std::sqrt(3.0);
  for (int width : {15, 30, 60}) {
    const double ratio = 1 - drop(width);
    const double error = ratio * std::hypot(sem / (5 * ratio), sem / 5);
    std::smatch m;
    const std::regex line(std::to_string(width) + "x" + std::to_string(width) +
                          R"(x10: drop (\S+) % ± (\S+) %)");
    REQUIRE(std::regex_search(r.out, m, line));
    CHECK(std::stod(m[1].str()) == Approx(100 * drop(width)).margin(0.05));
    CHECK(std::stod(m[2].str()) == Approx(100 * error).margin(0.05));
  }
  std::smatch m;
  REQUIRE(std::regex_search(r.out, m, std::regex(R"(L -> infinity: (\S+) % \+- (\S+) %)")));
  CHECK(std::stod(m[1].str()) == Approx(10.0).margin(0.01));
  CHECK(std::stod(m[2].str()) > 0.0);
  // The line's drop at twice the widest L, where a run would test it.
  REQUIRE(std::regex_search(r.out, m, std::regex(R"(1/L model: drop at 120 wide (\S+) %)")));
  CHECK(std::stod(m[1].str()) == Approx(100 * drop(120)).margin(0.01));
  // The block-scale period: (to − from)/(crossings − 1) = 10 ms.
  CHECK_THAT(slurp(box.work / "fs" / "finite_size.csv"), Catch::Contains(",10,4,"));
}

TEST_CASE("finite_size.py: a drop vanishing as a power law of L is found as one, beside the line",
          "[plots]") {
  Sandbox box("stickslip_plots_");
  // 0.3 L^-0.25: 15.2 %, 12.8 %, 10.8 % at 15, 30, 60 wide, 9.1 % at 120.
  const auto power_law = [](int width) { return 0.3 * std::pow(width, -0.25); };
  write_finite_size_points(box.work / "fs", {1, 2, 3}, power_law);
  const auto r = python(box, "finite_size.py", "fs");
  INFO(r.out);
  REQUIRE(r.code == 0);
  std::smatch m;
  REQUIRE(std::regex_search(
      r.out, m,
      std::regex(
          R"(power law to zero: p = (\S+) \+- (\S+) \(chi2 (\S+)\); drop at 120 wide (\S+) %)")));
  CHECK(std::stod(m[1].str()) == Approx(0.25).margin(1e-3));
  CHECK(std::stod(m[2].str()) > 0.0);
  CHECK(std::stod(m[3].str()) < 1e-4);  // exact data: the power law passes through every point
  CHECK(std::stod(m[4].str()) == Approx(100 * power_law(120)).margin(0.01));
  // The line cannot: it misses, and says by how much.
  REQUIRE(
      std::regex_search(r.out, m, std::regex(R"(L -> infinity: \S+ % \+- \S+ % \(chi2 (\S+))")));
  CHECK(std::stod(m[1].str()) > 1e-3);
  CHECK_THAT(slurp(box.work / "fs" / "finite_size.csv"),
             Catch::Contains("model,limit,limit_error,chi2,width,drop_there\na + b/L,"));
}

TEST_CASE(
    "finite_size.py: a width with one seed at a load takes that load's error from the narrower "
    "lattice's seeds, and says so",
    "[plots]") {
  Sandbox box("stickslip_plots_");
  write_finite_size_points(box.work / "fs", {2});  // 60 wide, θ = 0.04: seed 2 alone, μ = 5
  const auto r = python(box, "finite_size.py", "fs");
  INFO(r.out);
  REQUIRE(r.code == 0);
  check_png(box.work / "fs" / "finite_size.png");
  // Its s.e. is the 30-wide seeds' sd at θ = 0.04 (0.05), not theirs over √3;
  // θ = 0.498 keeps its own three seeds.
  const double ratio = 1 - finite_size_drop(60);
  const double error = ratio * std::hypot(0.05 / std::sqrt(3.0) / (5 * ratio), 0.05 / 5);
  std::smatch m;
  REQUIRE(std::regex_search(r.out, m,
                            std::regex(R"(60x60x10: drop (\S+) % ± (\S+) % \(error assumed\))")));
  CHECK(std::stod(m[1].str()) == Approx(100 * finite_size_drop(60)).margin(0.05));
  CHECK(std::stod(m[2].str()) == Approx(100 * error).margin(0.05));
  // Three widths with an error: the line, flagged as resting on an assumed one.
  REQUIRE(std::regex_search(
      r.out, m, std::regex(R"(L -> infinity: (\S+) % \+- (\S+) % .*with an assumed error)")));
  CHECK(std::stod(m[1].str()) == Approx(10.0).margin(0.01));
  const std::string csv = slurp(box.work / "fs" / "finite_size.csv");
  CHECK_THAT(csv, Catch::Contains("60x60x10,0.04,1,5,,0.05 (assumed)"));
  CHECK_THAT(csv, Catch::Contains("(assumed)\ninfinity,"));
}

namespace {

// A run with events, made up: F_f a sawtooth rising from 1 to 2 N over 10 ms
// and falling at 15, 25 and 35 ms (samples every 0.1 ms, window [10, 40] ms),
// ten contacts, and slips (onset, arrest in ms) laid out so that each block
// slip's contacts are known.
void write_census_run(const fs::path& dir, const std::string& events) {
  fs::create_directories(dir);
  const nlohmann::json summary = {
      {"case",
       {{"lattice", {{"nx", 15}, {"ny", 15}, {"nz", 10}}}, {"output", {{"events", events}}}}},
      {"contacts", 10},
      {"average_from", 0.010},
      {"F_N", 0.01},
      {"theta", 0.5}};
  std::ofstream(dir / "summary.json") << summary.dump();
  std::ofstream friction(dir / "friction.csv");
  friction << "t,F_f,mu_inst\n";
  for (int i = 0; i <= 400; ++i) {
    const double t_ms = 0.1 * i;
    const double since_fall = 0.1 * ((i + 50) % 100);  // [ms]: falls at 5, 15, 25, 35 ms
    const double f = 1.0 + since_fall / 10.0;
    friction << t_ms * 1e-3 << "," << f << "," << f / 0.01 << "\n";
  }
  if (events == "none") return;
  struct Slip {
    int contact;
    double onset_ms, arrest_ms;
  };
  // At 5 ms: before the window. At 15 ms: 0 and 1 overlap the drop (14.9 to
  // 15.0 ms), 2 too; 3 only through 2, and 0 slips again within the chain: 5
  // slips, 4 contacts. At 20 ms: 5 alone, while the block loads. At 25 ms: 2
  // contacts; 7 slips after a quiet moment, on its own.
  std::vector<Slip> slips = {
      {8, 5.0, 5.01},   {0, 14.88, 14.93}, {1, 14.92, 14.97}, {2, 14.96, 15.2},  {3, 15.15, 15.3},
      {0, 15.1, 15.12}, {5, 20.0, 20.01},  {4, 24.85, 24.95}, {6, 24.95, 25.02}, {7, 25.5, 25.6}};
  for (int c = 0; c < 10; ++c) slips.push_back({c, 34.9, 35.05});  // at 35 ms: all ten
  std::ofstream table(dir / "slips.csv");
  table << "t_end,contact,t_start,duration,slip,peak_speed,load_start,load_end,load_drop,"
           "F_f_start,F_f_end,F_f_drop\n";
  for (const Slip& s : slips)
    table << s.arrest_ms * 1e-3 << "," << s.contact << "," << s.onset_ms * 1e-3 << ","
          << (s.arrest_ms - s.onset_ms) * 1e-3 << ",0,0,0,0,0,0,0,0\n";
}

}  // namespace

TEST_CASE("block_slips.py: each block slip's contacts, chained through F_f's drop, and the period",
          "[plots]") {
  Sandbox box("stickslip_plots_");
  write_census_run(box.work / "run", "all");
  const auto r = python(box, "block_slips.py", "run");
  INFO(r.out);
  REQUIRE(r.code == 0);
  check_png(box.work / "run" / "block_slips.png");
  // Falls at 15, 25 and 35 ms, all three whole in the window: 4, 2 and 10 of
  // the 10 contacts, a mean of 53.3 %; the lone slips at 20 and 25.5 ms lie
  // outside them, the one at 5 ms outside the window.
  std::smatch m;
  REQUIRE(std::regex_search(
      r.out, m,
      std::regex(
          R"((\d+) block slips, period (\S+) ms, contacts per block slip (\S+) % \((\S+)–(\S+) %\))")));
  CHECK(m[1].str() == "3");
  CHECK(std::stod(m[2].str()) == Approx(10.0).margin(1e-6));
  CHECK(std::stod(m[3].str()) == Approx(100.0 * 16 / 30).margin(0.05));
  CHECK(std::stod(m[4].str()) == Approx(20.0));
  CHECK(std::stod(m[5].str()) == Approx(100.0));
  CHECK_THAT(r.out, Catch::Contains("2 of the window's 19 slips outside them"));
  const std::string csv = slurp(box.work / "run" / "block_slips.csv");
  CHECK_THAT(csv, Catch::Contains(",5,4,0.4000\n"));
  CHECK_THAT(csv, Catch::Contains(",2,2,0.2000\n"));
  CHECK_THAT(csv, Catch::Contains(",10,10,1.0000\n"));
  CHECK_THAT(csv, Catch::Contains("0.01488,0.0153,"));  // the first block slip's span
}

TEST_CASE("block_slips.py refuses a run whose events were not all located", "[plots]") {
  Sandbox box("stickslip_plots_");
  write_census_run(box.work / "run", "none");
  const auto r = python(box, "block_slips.py", "run");
  CHECK(r.code == 2);
  CHECK_THAT(r.out, Catch::Contains("events = \"all\""));
  CHECK_FALSE(fs::exists(box.work / "run" / "block_slips.csv"));
}

namespace {

// The column `name` of `columns` (read_run_columns), or a failed test.
const std::vector<double>& named(const stickslip::NamedColumns& columns, const std::string& name) {
  for (const auto& [n, values] : columns)
    if (n == name) return values;
  FAIL("no column " << name);
  throw;
}

}  // namespace

// [slow]: a 1.5 s run and four Python start-ups (the GIF's ~70 frames ~4 s).
TEST_CASE("block_slip_map.py: the contacts of a real run's block slip, its front and its movie",
          "[slow][plots]") {
  Sandbox box("stickslip_plots_");
  // 18 contacts on 6x6x4 from rest: block slips at 4.16 and 6.84 ms, both
  // wholly in the window [3, 7.5] ms.
  box.write("tiny.toml", R"([lattice]
nx = 6
ny = 6
nz = 4
[interface]
coverage = 0.5
[run]
t_end = 7.5e-3
average_from = 3e-3
[output]
interval = 1e-6
traces = "all"
)");
  REQUIRE(box.run({"run", "tiny.toml", "--out", "run", "--quiet", "--threads", "1"}).code == 0);
  REQUIRE(python(box, "block_slips.py", "run").code == 0);
  const auto census = read_run_columns(box.work / "run", "block_slips");
  REQUIRE(named(census, "first_onset").size() == 2);
  const auto slips = read_run_columns(box.work / "run", "slips");
  const auto& t_start = named(slips, "t_start");
  const auto& contact = named(slips, "contact");

  for (const int n : {0, 1}) {
    INFO("block slip " << n);
    const auto r = python(box, "block_slip_map.py", "run --slip " + std::to_string(n));
    INFO(r.out);
    REQUIRE(r.code == 0);
    check_png(box.work / "run" / "block_slip_map.png");
    // The contacts it says slipped: those of slips.csv's rows starting in the
    // census's span of that block slip, each counted once.
    const double first = named(census, "first_onset")[n];
    const double last = named(census, "last_arrest")[n];
    std::set<int> in_span;
    for (std::size_t i = 0; i < t_start.size(); ++i)
      if (t_start[i] >= first * (1 - 1e-9) && t_start[i] <= last * (1 + 1e-9))
        in_span.insert(static_cast<int>(contact[i]));
    REQUIRE_FALSE(in_span.empty());
    std::smatch m;
    REQUIRE(std::regex_search(
        r.out, m,
        std::regex(
            R"(block slip (\d+) .*: (\d+) of 18 contacts slipped.* front speed (\S+) ± (\S+) m/s)")));
    CHECK(m[1].str() == std::to_string(n));
    CHECK(std::stoul(m[2].str()) == in_span.size());
    // Faster than nothing, and within the lattice's elastic wave speeds'
    // range: c_t = 57.7 m/s, the front runs at 100-odd m/s on 6x6x4.
    CHECK(std::stod(m[3].str()) > 20.0);
    CHECK(std::stod(m[3].str()) < 1000.0);
    CHECK(std::stod(m[4].str()) > 0.0);
  }

  // Past the last block slip: a one-line error naming the run and the count.
  const auto beyond = python(box, "block_slip_map.py", "run --slip 2");
  CHECK(beyond.code == 2);
  CHECK(test::lines(beyond.out) == 1);
  CHECK_THAT(beyond.out, Catch::Contains("error: run: no block slip 2: the run has 2 block slips"));

  // The movie: a GIF of the contacts' speeds, a frame per traced row of the slip.
  fs::remove(box.work / "run" / "block_slip_map.png");
  const auto film = python(box, "block_slip_map.py", "run --movie");
  INFO(film.out);
  REQUIRE(film.code == 0);
  check_png(box.work / "run" / "block_slip_map.png");
  const std::string gif = slurp(box.work / "run" / "block_slip_0.gif");
  CHECK(gif.substr(0, 6) == "GIF89a");
  std::smatch frames;
  REQUIRE(std::regex_search(film.out, frames, std::regex(R"(block_slip_0\.gif \((\d+) frames\))")));
  // The slip lasts ~57 µs, traced every µs, with a tenth of it either side.
  CHECK(std::stoi(frames[1].str()) > 40);
  CHECK(gif.size() > 10'000);
}

TEST_CASE("block_slip_map.py: the front speed on a torus, and what it refuses", "[plots]") {
  Sandbox box("stickslip_plots_");
  // F_f's sawtooth of the census test (its fall at 15 ms is the one block
  // slip with slips), and a front made up: on a 15x15 lattice of spacing
  // 1e-4 m, contact 0 at (1, 1) slips first, at 14.9 ms; each other contact
  // 10 µs later plus its distance over 50 m/s, the distance taken across the
  // periodic edges where that is shorter: (14, 1) is 2 spacings away, not 13.
  write_census_run(box.work / "run", "none");
  nlohmann::json summary = nlohmann::json::parse(slurp(box.work / "run" / "summary.json"));
  summary["case"]["lattice"]["spacing"] = 1e-4;
  summary["case"]["interface"] = {{"patch", 1}};
  summary["case"]["output"] = {{"events", "all"}, {"traces", "none"}};
  summary["contacts"] = 7;
  std::ofstream(box.work / "run" / "summary.json") << summary.dump();
  const std::vector<std::array<int, 2>> sites{{1, 1}, {14, 1}, {1, 13}, {5, 1},
                                              {4, 5}, {8, 8},  {10, 10}};
  const std::vector<double> spacings{0, 2, 3, 4, 5, std::hypot(7.0, 7.0), std::hypot(6.0, 6.0)};
  std::ofstream contacts(box.work / "run" / "contacts.csv");
  contacts << "id,ix,iy,v_star\n";
  for (std::size_t i = 0; i < sites.size(); ++i)
    contacts << i << "," << sites[i][0] << "," << sites[i][1] << ",0.001\n";
  contacts.close();
  std::ofstream table(box.work / "run" / "slips.csv");
  table << std::setprecision(15)
        << "t_end,contact,t_start,duration,slip,peak_speed,load_start,load_end,load_drop,"
           "F_f_start,F_f_end,F_f_drop\n";
  table << 0.01502 << ",0," << 0.0149 << ",1.2e-4,0,0,0,0,0,0,0,0\n";
  for (std::size_t i = 1; i + 1 < sites.size(); ++i) {  // the last contact does not slip
    const double onset = 0.0149 + 10e-6 + spacings[i] * 1e-4 / 50.0;
    table << 0.01501 << "," << i << "," << onset << "," << 0.01501 - onset << ",0,0,0,0,0,0,0,0\n";
  }
  table.close();

  const auto r = python(box, "block_slip_map.py", "run");
  INFO(r.out);
  REQUIRE(r.code == 0);
  check_png(box.work / "run" / "block_slip_map.png");
  CHECK_THAT(r.out, Catch::Contains("6 of 7 contacts slipped, the first contact 0 at (1, 1)"));
  CHECK_THAT(r.out, Catch::Contains("14.0 µs ahead of the next"));  // (14, 1): 10 + 2e-4/50 s
  std::smatch m;
  REQUIRE(std::regex_search(r.out, m, std::regex(R"(front speed (\S+) ± (\S+) m/s over 5)")));
  CHECK(std::stod(m[1].str()) == Approx(50.0).epsilon(1e-6));
  CHECK(std::stod(m[2].str()) < 1e-6);

  // One block slip wholly in the window: --slip 1 is past it.
  const auto beyond = python(box, "block_slip_map.py", "run --slip 1");
  CHECK(beyond.code == 2);
  CHECK(test::lines(beyond.out) == 1);
  CHECK_THAT(beyond.out, Catch::Contains("error: run: no block slip 1: the run has 1 block slip "
                                         "wholly in its window [0.01, 0.04] s"));
  // A movie needs every contact's trace.
  const auto film = python(box, "block_slip_map.py", "run --movie");
  CHECK(film.code == 2);
  CHECK(test::lines(film.out) == 1);
  CHECK_THAT(film.out, Catch::Contains("run: --movie needs every contact's speed") &&
                           Catch::Contains("[output] traces = \"all\""));
  CHECK_FALSE(fs::exists(box.work / "run" / "block_slip_0.gif"));
  // A run without slips.csv: refused, naming the key, nothing drawn.
  fs::remove(box.work / "run" / "block_slip_map.png");
  fs::remove(box.work / "run" / "block_slip_map.pdf");
  fs::remove(box.work / "run" / "slips.csv");
  const auto gone = python(box, "block_slip_map.py", "run");
  CHECK(gone.code == 2);
  CHECK(test::lines(gone.out) == 1);
  CHECK_THAT(gone.out, Catch::Contains("error: run: no slips (run/slips.csv not found)") &&
                           Catch::Contains("[output] events = \"all\""));
  CHECK_FALSE(fs::exists(box.work / "run" / "block_slip_map.png"));
  // And one whose events were not located: it says so.
  write_census_run(box.work / "quiet", "none");
  const auto none = python(box, "block_slip_map.py", "quiet");
  CHECK(none.code == 2);
  CHECK(test::lines(none.out) == 1);
  CHECK_THAT(none.out, Catch::Contains("error: quiet: no slips of every contact ([output] events "
                                       "= \"none\"); the map needs them"));
  CHECK_FALSE(fs::exists(box.work / "quiet" / "block_slip_map.png"));
}

TEST_CASE("cost_scaling.py fits the exponent of wall per simulated ms against the nodes",
          "[plots]") {
  Sandbox box("stickslip_plots_");
  // Wall per ms exactly 1e-3 · nodes^1.5 at θ = 0.04, a range whose geometric
  // mean is 2e-3 · nodes at θ = 0.5: the fits must give 1.50 and 1.00.
  std::string table =
      "nx,ny,nz,theta,contacts,method,wall_per_ms_lo,wall_per_ms_hi,memory_MB,what\n";
  for (int n : {10, 20, 40}) {
    const double nodes = n * n * 10.0;
    char row[256];
    std::snprintf(row, sizeof row, "%d,%d,10,0.04,9,dirk,%.17g,%.17g,%.17g,whole\n", n, n,
                  1e-3 * std::pow(nodes, 1.5), 1e-3 * std::pow(nodes, 1.5), 2e-3 * nodes);
    table += row;
    std::snprintf(row, sizeof row, "%d,%d,10,0.5,9,multirate,%.17g,%.17g,,whole\n", n, n,
                  1e-3 * nodes, 4e-3 * nodes);
    table += row;
  }
  fs::create_directories(box.work / "cost");
  box.write("cost/cost.csv", table);
  const auto r = python(box, "cost_scaling.py", "cost");
  INFO(r.out);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("theta=0.04 wall_per_ms ~ nodes^1.50 memory 1.95 KiB/node"));
  CHECK_THAT(r.out, Catch::Contains("theta=0.5 wall_per_ms ~ nodes^1.00\n"));
  check_png(box.work / "cost" / "cost_scaling.png");
}
