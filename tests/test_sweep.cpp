// `stickslip sweep` through the real binary: the rows a sweep makes, what a
// second start runs (nothing, or only the unfinished points), stale results
// refused, MPI ranks against local jobs, and bad sweep files.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "sandbox.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/sweep/sweep.hpp"
#include "stickslip/version.hpp"
#include "test_cases.hpp"

namespace test = stickslip::test;

using test::Sandbox;
using test::slurp;
namespace fs = std::filesystem;

namespace {

const char* kTiny = R"([sweep]
case = "base.toml"
[vary]
interface.coverage = [0.2, 0.5]
interface.seed = [1, 2]
)";

std::vector<std::vector<std::string>> csv(const fs::path& file) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(slurp(file));
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> row;
    std::istringstream fields(line);
    for (std::string f; std::getline(fields, f, ',');) row.push_back(f);
    if (!line.empty() && line.back() == ',') row.emplace_back();
    rows.push_back(row);
  }
  return rows;
}

std::size_t column(const std::vector<std::vector<std::string>>& rows, const std::string& name) {
  const auto& h = rows.at(0);
  const auto it = std::find(h.begin(), h.end(), name);
  REQUIRE(it != h.end());
  return static_cast<std::size_t>(it - h.begin());
}

fs::file_time_type mtime(const fs::path& p) {
  return fs::last_write_time(p);
}

}  // namespace

TEST_CASE("a sweep runs every combination once, and started again only what is unfinished",
          "[sweep]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  box.write("tiny.toml", kTiny);
  const auto first = box.run({"sweep", "tiny.toml", "--jobs", "2"});
  INFO(first.out << first.err);
  REQUIRE(first.code == 0);
  const fs::path out = box.work / "out" / "tiny";
  auto rows = csv(out / "sweep.csv");
  REQUIRE(rows.size() == 5);  // header and 4 points, first axis slowest
  const auto cov = column(rows, "interface.coverage"), seed = column(rows, "interface.seed"),
             status = column(rows, "status"), mu = column(rows, "mu");
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"0.2", "1"}, {"0.2", "2"}, {"0.5", "1"}, {"0.5", "2"}};
  for (std::size_t i = 0; i < 4; ++i) {
    CHECK(rows[i + 1][cov] == expected[i].first);
    CHECK(rows[i + 1][seed] == expected[i].second);
    CHECK(rows[i + 1][status] == "finished");
    // Each row is its point's own result, and that point ran the right case.
    const fs::path dir = out / rows[i + 1][0];
    const auto summary = nlohmann::json::parse(slurp(dir / "summary.json"));
    CHECK(std::stod(rows[i + 1][mu]) == Approx(summary["mu"].get<double>()).epsilon(1e-9));
    CHECK(std::stod(rows[i + 1][column(rows, "F_f_spread")]) ==
          Approx(summary["F_f_spread"].get<double>()).epsilon(1e-9));
    CHECK(summary["case"]["interface"]["coverage"].get<double>() == std::stod(expected[i].first));
    CHECK(summary["case"]["interface"]["seed"].get<int>() == std::stoi(expected[i].second));
  }

  // The command line names the points whose μ is no friction coefficient
  // (sweep.csv's regime), each as it finishes and all of them at the end:
  // here every window is 0.2 ms of the loading ramp from rest.
  const auto regime = column(rows, "regime");
  std::size_t untrusted = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const std::string& r = rows[i][regime];
    if (r == "stick-slip" || r == "steady sliding") continue;
    ++untrusted;
    CHECK_THAT(first.out, Catch::Contains(rows[i][0] + ": mu = ") &&
                              Catch::Contains("not a friction coefficient (" + r + ")"));
  }
  CHECK(untrusted == 4);
  CHECK_THAT(first.out, Catch::Contains(std::to_string(untrusted) +
                                        " of them have a mu that is not a friction coefficient"));

  // sweep_summary.csv: μ over the seeds at each coverage.
  const auto means = csv(out / "sweep_summary.csv");
  REQUIRE(means.size() == 3);
  CHECK(means[0][0] == "interface.coverage");
  for (std::size_t g = 0; g < 2; ++g) {
    const double a = std::stod(rows[2 * g + 1][mu]), b = std::stod(rows[2 * g + 2][mu]);
    CHECK(std::stod(means[g + 1][column(means, "mu_mean")]) == Approx((a + b) / 2).epsilon(1e-9));
    CHECK(std::stod(means[g + 1][column(means, "mu_std")]) ==
          Approx(std::abs(a - b) / std::sqrt(2.0)).epsilon(1e-6));  // μ printed to 10 digits
    CHECK(means[g + 1][column(means, "count")] == "2");
    // The points' own error bars, beside the seeds' spread: √(e₁² + e₂²) / 2.
    const auto error = column(rows, "mu_error");
    const double ea = std::stod(rows[2 * g + 1][error]), eb = std::stod(rows[2 * g + 2][error]);
    CHECK(std::stod(means[g + 1][column(means, "mu_runs_error")]) ==
          Approx(std::hypot(ea, eb) / 2).epsilon(1e-6));
  }

  // --report writes the tables from what is finished and runs nothing.
  fs::remove_all(out / "coverage=0.5_seed=1");
  const auto report = box.run({"sweep", "tiny.toml", "--report"});
  CHECK(report.code == 1);
  CHECK_THAT(report.out, Catch::Contains("3 of 4 points finished"));
  CHECK_THAT(report.out, Catch::Contains("3 of them have a mu that is not a friction coefficient"));
  CHECK_FALSE(fs::exists(out / "coverage=0.5_seed=1"));
  const auto partial = csv(out / "sweep.csv");
  CHECK(partial[3][status] == "not run");
  CHECK(partial[3][mu].empty());
  CHECK(partial[4] == rows[4]);
  REQUIRE(box.run({"sweep", "tiny.toml", "--jobs", "2"}).code == 0);
  rows = csv(out / "sweep.csv");

  // Started again: nothing runs, no result is touched.
  const auto stamp = mtime(out / "coverage=0.5_seed=2" / "summary.json");
  const auto again = box.run({"sweep", "tiny.toml", "--jobs", "2"});
  CHECK(again.code == 0);
  CHECK_THAT(again.out, Catch::Contains("4 already were"));
  CHECK(mtime(out / "coverage=0.5_seed=2" / "summary.json") == stamp);

  // A point whose summary is cut short (a crash while writing) is run again, alone.
  const std::string whole = slurp(out / "coverage=0.2_seed=2" / "summary.json");
  test::spit(out / "coverage=0.2_seed=2" / "summary.json", whole.substr(0, whole.size() / 2));
  const auto resumed = box.run({"sweep", "tiny.toml", "--jobs", "2"});
  INFO(resumed.out << resumed.err);
  CHECK(resumed.code == 0);
  CHECK_THAT(resumed.out, Catch::Contains("3 already were"));
  CHECK_THAT(resumed.out, Catch::Contains("coverage=0.2_seed=2: mu ="));
  CHECK(mtime(out / "coverage=0.5_seed=2" / "summary.json") == stamp);
  auto rerun = csv(out / "sweep.csv");
  const auto wall = column(rows, "wall_seconds");
  for (auto* table : {&rows, &rerun})
    for (auto& row : *table) row.at(wall).clear();
  CHECK(rerun == rows);  // the same μ and statistics again: a run is deterministic
}

TEST_CASE("a sweep refuses results of another code version or case unless told to recompute",
          "[sweep]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  box.write("tiny.toml", kTiny);
  REQUIRE(box.run({"sweep", "tiny.toml", "--jobs", "2"}).code == 0);
  const fs::path point = box.work / "out" / "tiny" / "coverage=0.5_seed=1";
  auto summary = nlohmann::json::parse(slurp(point / "summary.json"));
  summary["provenance"]["git_commit"] = "0000000";
  test::spit(point / "summary.json", summary.dump());

  const auto refused = box.run({"sweep", "tiny.toml"});
  CHECK(refused.code == 2);
  CHECK_THAT(refused.err, Catch::Contains("coverage=0.5_seed=1") &&
                              Catch::Contains("code version 0000000") &&
                              Catch::Contains("--overwrite"));
  CHECK(nlohmann::json::parse(slurp(point / "summary.json"))["provenance"]["git_commit"] ==
        "0000000");  // untouched

  // --any-version keeps it, and its row names the version that computed it.
  const auto kept = box.run({"sweep", "tiny.toml", "--any-version"});
  INFO(kept.out << kept.err);
  CHECK(kept.code == 0);
  CHECK_THAT(kept.out, Catch::Contains("4 already were"));
  const auto table = slurp(box.work / "out" / "tiny" / "sweep.csv");
  CHECK_THAT(table, Catch::Contains("coverage=0.5_seed=1,") && Catch::Contains(",0000000,"));
  // Without it the point is stale: not counted (exit 1, not all finished).
  CHECK(box.run({"sweep", "tiny.toml", "--report"}).code == 1);
  CHECK_THAT(slurp(box.work / "out" / "tiny" / "sweep.csv"),
             !Catch::Contains(",0000000,") && Catch::Contains("stale"));

  // A changed base case makes every point stale.
  box.write("base.toml", std::string(test::kTinyBaseToml) + "[drive]\nvelocity = 2e-3\n");
  const auto changed = box.run({"sweep", "tiny.toml"});
  CHECK(changed.code == 2);
  CHECK_THAT(changed.err, Catch::Contains("different case") && Catch::Contains("3 more points"));

  const auto redone = box.run({"sweep", "tiny.toml", "--overwrite"});
  INFO(redone.out << redone.err);
  CHECK(redone.code == 0);
  CHECK_THAT(redone.out, Catch::Contains("0 already were"));
  summary = nlohmann::json::parse(slurp(point / "summary.json"));
  CHECK(summary["case"]["drive"]["velocity"].get<double>() == 2e-3);

  // A summary written before a key existed lacks it: it meant the key's
  // default, so the point stays finished if that is its value now...
  summary["case"]["interface"].erase("patch");  // 1, the default
  summary["case"]["solver"].erase("threads");
  test::spit(point / "summary.json", summary.dump());
  CHECK(box.run({"sweep", "tiny.toml", "--report"}).code == 0);
  // A whole section added later likewise.
  summary["case"].erase("damping");
  test::spit(point / "summary.json", summary.dump());
  CHECK(box.run({"sweep", "tiny.toml", "--report"}).code == 0);
  // An attempt by another code version (a restart with --any-version) makes
  // the point another version's result.
  auto mixed = summary;
  mixed["provenance"]["segments"] = {{{"from", 0.0}, {"git_commit", "0000000"}},
                                     {{"from", 1e-4}, {"git_commit", stickslip::kGitCommit}}};
  test::spit(point / "summary.json", mixed.dump());
  CHECK(box.run({"sweep", "tiny.toml", "--report"}).code == 1);
  CHECK(box.run({"sweep", "tiny.toml", "--report", "--any-version"}).code == 0);
  // ...and is stale if not (drive.velocity is 2e-3 here, its default 1e-3).
  summary["case"]["drive"].erase("velocity");
  test::spit(point / "summary.json", summary.dump());
  CHECK(box.run({"sweep", "tiny.toml", "--report"}).code == 1);
}

TEST_CASE("mpirun -n 2 gives the same sweep.csv as --jobs 2", "[sweep][mpi][may_skip]") {
#ifndef STICKSLIP_MPIEXEC
  // ctest reports the test as skipped on this line (tests/CMakeLists.txt).
  std::cout << "SKIPPED: built without MPI\n";
#else
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  box.write("tiny.toml", kTiny);
  REQUIRE(box.run({"sweep", "tiny.toml", "--jobs", "2", "--out", "jobs"}).code == 0);
  // OpenMPI refuses to run as root unless told; --oversubscribe for 1-core machines.
  const std::string cmd = "cd " + test::quote(box.work.string()) +
                          " && OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " +
                          STICKSLIP_MPIEXEC + " -n 2 --oversubscribe " +
                          test::quote(STICKSLIP_EXE) + " sweep tiny.toml --out mpi >mpi.txt 2>&1";
  const int status = std::system(cmd.c_str());
  INFO(slurp(box.work / "mpi.txt"));
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  CHECK_THAT(slurp(box.work / "mpi.txt"), Catch::Contains("on each of 2 MPI ranks"));
  auto a = csv(box.work / "jobs" / "sweep.csv"), b = csv(box.work / "mpi" / "sweep.csv");
  const auto wall = column(a, "wall_seconds");
  for (auto* rows : {&a, &b})
    for (auto& row : *rows) row.at(wall).clear();  // the only column that may differ
  CHECK(a == b);
  CHECK(slurp(box.work / "jobs" / "sweep_summary.csv") ==
        slurp(box.work / "mpi" / "sweep_summary.csv"));
#endif
}

TEST_CASE("bad sweep files are refused: exit 2, file, line and key, nothing run",
          "[sweep][bad_input]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  box.write("pair.toml",
            std::string(test::kTinyBaseToml) +
                "[interface]\ncontacts = [ { site = [1, 2], v_star = 4.75e-4 }, { site "
                "= [4, 2], v_star = 2.09e-3 } ]\n");
  struct Row {
    const char* name;
    std::string text;
    std::vector<const char*> message;
  };
  const std::vector<Row> rows = {
      {"a sweep key that does not exist",
       "[sweep]\ncase = \"base.toml\"\n[vary]\ninterface.covrage = [0.2, 0.5]\n",
       {"s.toml:4: vary.interface.covrage: unknown key 'covrage' (did you mean 'coverage'?)"}},
      {"a section that does not exist",
       "[sweep]\ncase = \"base.toml\"\n[vary]\nlatice.nx = [4]\n",
       {"s.toml:4: vary.latice.nx: unknown section 'latice' (did you mean 'lattice'?)"}},
      {"a value the case refuses",
       "[sweep]\ncase = \"base.toml\"\n[vary]\ninterface.coverage = [0.2,\n  1.5]\n",
       {"s.toml:5: vary.interface.coverage: value 1.5", "must be in (0, 1]"}},
      {"a combination the case refuses",
       "[sweep]\ncase = \"base.toml\"\n[vary]\nrun.t_end = [2e-4, 4e-4]\nrun.average_from = [1e-4, "
       "2.5e-4]\n",
       {"s.toml: point t_end=0.0002_average_from=0.00025", "average_from"}},
      {"no values",
       "[sweep]\ncase = \"base.toml\"\n[vary]\ninterface.seed = []\n",
       {"s.toml:4: vary.interface.seed: expected a non-empty list of values"}},
      {"a repeated value",
       "[sweep]\ncase = \"base.toml\"\n[vary]\ninterface.seed = [1, 2, 1]\n",
       {"s.toml:4: vary.interface.seed: repeats the value 1"}},
      {"no base case",
       "[sweep]\n[vary]\ninterface.seed = [1]\n",
       {"s.toml:1: sweep: missing case"}},
      {"a missing base case",
       "[sweep]\ncase = \"nope.toml\"\n[vary]\ninterface.seed = [1]\n",
       {"nope.toml: cannot read case file", "(base case of s.toml)"}},
      {"output.dir swept",
       "[sweep]\ncase = \"base.toml\"\n[vary]\noutput.dir = [\"a\", \"b\"]\n",
       {"s.toml:4: vary.output.dir: each point writes to its own directory"}},
      {"average_over not a key",
       "[sweep]\ncase = \"base.toml\"\naverage_over = \"interface.sed\"\n[vary]\ninterface.seed = "
       "[1]\n",
       {"s.toml:3: sweep.average_over: unknown key 'sed' (did you mean 'seed'?)"}},
      {"malformed TOML", "[sweep]\ncase = \"base.toml\n", {"s.toml:2: malformed TOML"}},
      {"keys together of different lengths",
       "[sweep]\ncase = \"base.toml\"\n[[vary.together]]\nlattice.nx = [6, 8]\nlattice.ny = [6, "
       "8, 10]\n",
       {"s.toml:5: vary.together.lattice.ny: expected a list as long as "
        "vary.together.lattice.nx's (2 values)"}},
      {"one key together",
       "[sweep]\ncase = \"base.toml\"\n[[vary.together]]\nlattice.nx = [6, 8]\n",
       {"s.toml:3: vary.together: needs at least two keys that change in step"}},
      {"seeds over an explicit contacts list (identical runs that would look like an ensemble)",
       "[sweep]\ncase = \"pair.toml\"\n[vary]\ninterface.seed = [1, 2, 3]\n",
       {"s.toml:4: vary.interface.seed", "interface.contacts lists them"}},
      {"coverages over an explicit contacts list",
       "[sweep]\ncase = \"pair.toml\"\n[vary]\ninterface.coverage = [0.1, 0.2]\n",
       {"s.toml:4: vary.interface.coverage", "interface.contacts lists them"}},
      {"a linked combination the case refuses",
       "[sweep]\ncase = \"base.toml\"\n[[vary.together]]\nlattice.nx = [6, 8]\ninterface.patch = "
       "[1, 7]\n",
       {"s.toml: point nx=8_patch=7 is refused by the case", "7x7 patch does not fit"}},
  };
  for (const auto& row : rows) {
    SECTION(row.name) {
      box.write("s.toml", row.text);
      const auto before = box.snapshot();
      const auto r = box.run({"sweep", "s.toml"});
      INFO(r.err);
      CHECK(r.code == 2);
      CHECK(test::lines(r.err) == 1);
      for (const char* m : row.message) CHECK_THAT(r.err, Catch::Contains(m));
      CHECK(box.snapshot() == before);  // nothing written, nothing run
    }
  }
}

TEST_CASE("[set] and [vary] values are judged on whole points, not on the base case alone",
          "[sweep][bad_input]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);  // t_end = 3e-4
  // average_from = 4e-4 is refused with the base case's t_end, and fine on every point.
  box.write("later.toml",
            "[sweep]\ncase = \"base.toml\"\n[set]\nrun.average_from = 4e-4\n[vary]\nrun.t_end = "
            "[5e-4, 6e-4]\n");
  const auto accepted = box.run({"sweep", "later.toml", "--report"});
  INFO(accepted.err);
  CHECK(accepted.code == 1);  // valid; no point finished yet
  CHECK_THAT(accepted.out, Catch::Contains("0 of 2 points finished"));
  box.write("both.toml",
            "[sweep]\ncase = \"base.toml\"\n[vary]\nrun.average_from = [4e-4, 4.5e-4]\nrun.t_end = "
            "[5e-4, 6e-4]\n");
  CHECK(box.run({"sweep", "both.toml", "--report"}).code == 1);
  // Refused on a point too: that point's error, which names the key.
  box.write("never.toml",
            "[sweep]\ncase = \"base.toml\"\n[set]\nrun.average_from = 7e-4\n[vary]\nrun.t_end = "
            "[5e-4, 6e-4]\n");
  const auto refused = box.run({"sweep", "never.toml", "--report"});
  CHECK(refused.code == 2);
  CHECK_THAT(refused.err,
             Catch::Contains("point t_end=0.0005 is refused") &&
                 Catch::Contains("run.average_from: must be in [0, run.t_end = 0.0005)"));
  // Refused for the base case's own reason: blamed as before, on the base case.
  box.write("bad.toml",
            "[sweep]\ncase = \"base.toml\"\n[set]\ninterface.coverage = 1.5\n[vary]\nrun.t_end = "
            "[5e-4, 6e-4]\n");
  const auto bad = box.run({"sweep", "bad.toml", "--report"});
  CHECK(bad.code == 2);
  CHECK_THAT(bad.err,
             Catch::Contains("interface.coverage") && Catch::Contains("(base case of bad.toml)"));
  // A point refused for another reason than the base case is blamed on that reason.
  box.write("other.toml",
            "[sweep]\ncase = \"base.toml\"\n[set]\nrun.average_from = 4e-4\nrun.t_end = "
            "5e-4\n[vary]\nlattice.nz = [4, 1]\n");
  const auto nz = box.run({"sweep", "other.toml", "--report"});
  CHECK(nz.code == 2);
  CHECK_THAT(nz.err, Catch::Contains("lattice.nz") && !Catch::Contains("average_from"));
  // A --set of a key the sweep varies would be lost on every point: refused.
  const auto lost = box.run({"sweep", "later.toml", "--report", "--set", "run.t_end=1e-3"});
  CHECK(lost.code == 2);
  CHECK_THAT(lost.err, Catch::Contains("--set run.t_end: later.toml varies it"));
}

TEST_CASE("keys in [[vary.together]] change in step, the groups combine", "[sweep]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  const auto file = box.write("s.toml", R"([sweep]
case = "base.toml"
[vary]
interface.seed = [1, 2]
[[vary.together]]
lattice.nx = [6, 12, 18]
lattice.ny = [6, 12, 18]
lattice.nz = [4, 4, 8]
interface.patch = [1, 2, 3]
)");
  const auto sweep = stickslip::read_sweep(file);
  const auto points = stickslip::sweep_points(sweep);
  REQUIRE(points.size() == 6);  // 2 seeds × 3 sizes, not 2 × 3⁴
  CHECK(points[0].name == "seed=1_nx=6_ny=6_nz=4_patch=1");
  CHECK(points[5].name == "seed=2_nx=18_ny=18_nz=8_patch=3");
  for (const auto& p : points) {
    CHECK(p.c.lattice.nx == 6 * p.c.interface.patch);
    CHECK(p.c.lattice.ny == p.c.lattice.nx);
    CHECK(p.c.lattice.nz == (p.c.interface.patch == 3 ? 8 : 4));
  }
  CHECK(points[1].c.interface.seed == 1);
  CHECK(points[3].c.interface.seed == 2);
}

TEST_CASE("every file in cases/ is a valid case or sweep", "[sweep][cases]") {
  std::size_t cases = 0, sweeps = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(STICKSLIP_SOURCE_DIR) / "cases")) {
    if (entry.path().extension() != ".toml") continue;
    INFO(entry.path());
    if (slurp(entry.path()).find("[sweep]") != std::string::npos) {
      const auto sweep = stickslip::read_sweep(entry.path());
      CHECK(stickslip::sweep_points(sweep).size() >= 1);
      ++sweeps;
    } else {
      CHECK_NOTHROW(stickslip::read_case(entry.path()));
      ++cases;
    }
  }
  CHECK(cases >= 6);
  CHECK(sweeps >= 6);
}

TEST_CASE("every file in bench/cases/ is a valid case", "[sweep][cases]") {
  std::size_t cases = 0;
  for (const auto& entry :
       fs::directory_iterator(fs::path(STICKSLIP_SOURCE_DIR) / "bench" / "cases")) {
    INFO(entry.path());
    CHECK(entry.path().extension() == ".toml");
    CHECK_NOTHROW(stickslip::read_case(entry.path()));
    ++cases;
  }
  CHECK(cases >= 4);
}

TEST_CASE("an interrupted sweep continues its stopped points from their checkpoints",
          "[slow][sweep][restart]") {
  Sandbox box;
  // Two contacts through several slips: a restart starts the integrator
  // afresh, which perturbs the solution at the level of rtol and shifts
  // slips. At rtol 1e-6 that moved μ by up to 1.8e-5 over a 2 ms window (with
  // the machine loaded, where the stop falls elsewhere); at rtol 1e-7 the
  // perturbation is ten times smaller.
  box.write("two.toml", std::string(stickslip::test::kTwoContactToml) + R"([solver]
rtol = 1e-7
[run]
t_end = 3e-3
average_from = 1e-3
[output]
interval = 1e-5
)");
  box.write("s.toml", "[sweep]\ncase = \"two.toml\"\n[vary]\ndrive.velocity = [1e-3, 1.2e-3]\n");
  REQUIRE(box.run({"sweep", "s.toml", "--jobs", "2", "--out", "whole"}).code == 0);

  // SIGTERM to the sweep alone, once both points are under way: it passes the
  // signal on, each point writes a checkpoint, the sweep exits 143.
  const std::string cmd = "cd " + test::quote(box.work.string()) + " && (" +
                          test::quote(STICKSLIP_EXE) +
                          " sweep s.toml --jobs 2 --out part >part.txt 2>&1 & pid=$!; "
                          "while [ $(ls part/*/friction.csv 2>/dev/null | wc -l) -lt 2 ]; do "
                          "sleep 0.05; done; sleep 0.3; kill -TERM $pid; wait $pid)";
  const int status = std::system(cmd.c_str());
  INFO(slurp(box.work / "part.txt"));
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 143);
  int stopped = 0;
  for (const auto& p : fs::directory_iterator(box.work / "part"))
    if (fs::exists(p.path() / "checkpoint.bin")) {
      CHECK_FALSE(fs::exists(p.path() / "summary.json"));
      ++stopped;
    }
  CHECK(stopped >= 1);
  std::vector<fs::path> stopped_points;
  for (const auto& p : fs::directory_iterator(box.work / "part"))
    if (fs::exists(p.path() / "checkpoint.bin")) stopped_points.push_back(p.path());

  const auto resumed = box.run({"sweep", "s.toml", "--jobs", "2", "--out", "part"});
  INFO(resumed.out << resumed.err);
  REQUIRE(resumed.code == 0);
  // Continued, not started afresh: the log of the first attempt is kept.
  for (const auto& p : stopped_points) {
    const std::string log = slurp(p / "run.log");
    CHECK_THAT(log, Catch::Contains("interrupted at t = ") && Catch::Contains("mu = "));
  }
  // The continued points agree with the uninterrupted sweep to the tolerance.
  const auto whole = csv(box.work / "whole" / "sweep.csv"),
             part = csv(box.work / "part" / "sweep.csv");
  REQUIRE(whole.size() == 3);
  REQUIRE(part.size() == 3);
  const auto mu = column(whole, "mu");
  for (std::size_t i = 1; i < 3; ++i) {
    CHECK(part[i][column(part, "status")] == "finished");
    CHECK(std::stod(part[i][mu]) == Approx(std::stod(whole[i][mu])).epsilon(1e-5));
    CHECK(part[i][column(part, "slips")] == whole[i][column(whole, "slips")]);
  }
  // Rows continue without gaps or duplicates.
  for (const auto& p : fs::directory_iterator(box.work / "part"))
    if (p.is_directory())
      CHECK(test::lines(slurp(p.path() / "friction.csv")) ==
            test::lines(slurp(box.work / "whole" / p.path().filename() / "friction.csv")));
}

TEST_CASE("SIGINT to a sweep alone stops its running points with a checkpoint",
          "[sweep][restart]") {
  // What a notebook's "interrupt kernel" does to stickslip.sweep, and `kill
  // -INT` to the command: the signal reaches the sweep's process only, not
  // its process group. Two points of the pair under imex at rtol 1e-7 for
  // 0.1 s of sliding: minutes of computing each, so a point that is not
  // stopped is still running when the sweep is given up on, 20 s after the
  // signal (and then stopped with SIGTERM, which the sweep passes on).
  Sandbox box;
  box.write("two.toml", std::string(stickslip::test::kTwoContactToml) + R"([run]
t_end = 0.1
average_from = 1e-3
checkpoint_every = 1e-3
[solver]
method = "imex"
rtol = 1e-7
atol_displacement = 1e-13
atol_velocity = 1e-8
)");
  box.write("s.toml", "[sweep]\ncase = \"two.toml\"\n[vary]\ndrive.velocity = [1e-3, 1.2e-3]\n");
  const std::string cmd =
      "cd " + test::quote(box.work.string()) + " && (" + test::quote(STICKSLIP_EXE) +
      " sweep s.toml --jobs 2 --out part >part.txt 2>&1 & pid=$!; "
      "while [ $(ls part/*/friction.csv 2>/dev/null | wc -l) -lt 2 ]; do sleep 0.02; done; "
      "kill -INT $pid; i=0; while kill -0 $pid 2>/dev/null && [ $i -lt 1000 ]; do "
      "sleep 0.02; i=$((i+1)); done; "
      "if kill -0 $pid 2>/dev/null; then echo 'still running' >>part.txt; kill -TERM $pid; fi; "
      "wait $pid)";
  const int status = std::system(cmd.c_str());
  const std::string log = slurp(box.work / "part.txt");
  INFO(log);
  REQUIRE(WIFEXITED(status));
  CHECK_THAT(log, !Catch::Contains("still running"));
  CHECK(WEXITSTATUS(status) == 130);
  int stopped = 0;
  for (const auto& p : fs::directory_iterator(box.work / "part")) {
    if (!p.is_directory()) continue;
    INFO(p.path());
    const std::string run_log = slurp(p.path() / "run.log");
    INFO(run_log);
    // Each stopped itself, early in its 0.1 s, and kept a checkpoint.
    const auto at = run_log.find("interrupted at t = ");
    REQUIRE(at != std::string::npos);
    CHECK(std::strtod(run_log.c_str() + at + 19, nullptr) < 0.05);
    CHECK(fs::exists(p.path() / "checkpoint.bin"));
    CHECK_FALSE(fs::exists(p.path() / "summary.json"));
    ++stopped;
  }
  CHECK(stopped == 2);
}

TEST_CASE("a sweep split into job-array shards makes the same tables as one run",
          "[sweep][shard]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  box.write("tiny.toml", kTiny);
  REQUIRE(box.run({"sweep", "tiny.toml", "--jobs", "2", "--out", "whole"}).code == 0);

  // The cluster script, as Slurm starts it for --array=1-3 (task ids 1, 2, 3):
  // shard 0 runs points 0 and 3, shards 1 and 2 one point each.
  const std::string script =
      std::string(STICKSLIP_SOURCE_DIR) + "/scripts/cluster/sweep-array.sbatch";
  const std::vector<std::string> mine = {"coverage=0.2_seed=1", "coverage=0.2_seed=2",
                                         "coverage=0.5_seed=1"};
  for (int task = 1; task <= 3; ++task) {
    const std::string log = "shard" + std::to_string(task) + ".txt";
    const std::string cmd = "cd " + test::quote(box.work.string()) +
                            " && SLURM_ARRAY_TASK_ID=" + std::to_string(task) +
                            " SLURM_ARRAY_TASK_MIN=1 SLURM_ARRAY_TASK_MAX=3"
                            " SLURM_ARRAY_TASK_COUNT=3 STICKSLIP=" +
                            test::quote(STICKSLIP_EXE) + " " + test::quote(script) +
                            " tiny.toml --out shards >" + log + " 2>&1";
    const int status = std::system(cmd.c_str());
    const std::string out = slurp(box.work / log);
    INFO(out);
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 0);
    CHECK_THAT(out, Catch::Contains("shard " + std::to_string(task - 1) + "/3"));
    CHECK_THAT(out, Catch::Contains(mine[task - 1] + ": mu ="));
    // Only this shard's points ran: the next shard's point is not there yet.
    if (task < 3) CHECK_FALSE(fs::exists(box.work / "shards" / mine[task]));
  }
  CHECK_THAT(slurp(box.work / "shard1.txt"), Catch::Contains("coverage=0.5_seed=2: mu ="));
  CHECK_THAT(slurp(box.work / "shard3.txt"),
             Catch::Contains("4 of 4 points of the sweep finished"));

  auto a = csv(box.work / "whole" / "sweep.csv"), b = csv(box.work / "shards" / "sweep.csv");
  const auto wall = column(a, "wall_seconds");
  for (auto* rows : {&a, &b})
    for (auto& row : *rows) row.at(wall).clear();
  CHECK(a == b);
  CHECK(slurp(box.work / "whole" / "sweep_summary.csv") ==
        slurp(box.work / "shards" / "sweep_summary.csv"));

  // A shard run again has nothing left to do.
  const auto again = box.run({"sweep", "tiny.toml", "--out", "shards", "--shard", "0/3"});
  CHECK(again.code == 0);
  CHECK_THAT(again.out, Catch::Contains("0 of its points ran"));

  // Bad shards, and arrays the script cannot split evenly, are refused before anything runs.
  for (const char* bad : {"3/3", "1", "-1/2", "a/2", "1/0", "0/2/3"}) {
    const auto r = box.run({"sweep", "tiny.toml", "--out", "bad", "--shard", bad});
    INFO(bad);
    CHECK(r.code == 2);
    CHECK_THAT(r.err,
               Catch::Contains(std::string("--shard ") + bad) && Catch::Contains("0 <= i < n"));
  }
  CHECK_FALSE(fs::exists(box.work / "bad" / "coverage=0.2_seed=1"));
  const std::string stepped = "cd " + test::quote(box.work.string()) +
                              " && SLURM_ARRAY_TASK_ID=2 SLURM_ARRAY_TASK_MIN=0 "
                              "SLURM_ARRAY_TASK_MAX=4 SLURM_ARRAY_TASK_STEP=2 "
                              "SLURM_ARRAY_TASK_COUNT=3 STICKSLIP=" +
                              test::quote(STICKSLIP_EXE) + " " + test::quote(script) +
                              " tiny.toml --out stepped >stepped.txt 2>&1";
  const int status = std::system(stepped.c_str());
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 2);
  CHECK_THAT(slurp(box.work / "stepped.txt"), Catch::Contains("one range FIRST-LAST"));
  CHECK_FALSE(fs::exists(box.work / "stepped"));
}

TEST_CASE("points side by side run on one thread each, one at a time, on the case's threads",
          "[sweep][threads]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  box.write("tiny.toml", kTiny);
  // Every point's case asks for three threads: side by side the sweep
  // overrides it, one at a time it stands. (The default, 0, would mean one
  // thread on this 144-node lattice anyway: kMinNodesForThreads.)
  const auto side_by_side =
      box.run({"sweep", "tiny.toml", "--jobs", "2", "--out", "two", "--set", "solver.threads=3"});
  const auto one_at_a_time =
      box.run({"sweep", "tiny.toml", "--jobs", "1", "--out", "one", "--set", "solver.threads=3"});
  REQUIRE(side_by_side.code == 0);
  REQUIRE(one_at_a_time.code == 0);
  for (const auto& [dir, threads] : {std::pair{"two", 1}, std::pair{"one", 3}}) {
    int points = 0;
    for (const auto& entry : fs::directory_iterator(box.work / dir)) {
      if (!entry.is_directory()) continue;
      const auto summary = nlohmann::json::parse(slurp(entry.path() / "summary.json"));
      INFO(entry.path());
      CHECK(summary["solver"]["threads"] == threads);
      ++points;
    }
    CHECK(points == 4);
  }
  // The same numbers either way.
  CHECK(slurp(box.work / "two" / "sweep_summary.csv") ==
        slurp(box.work / "one" / "sweep_summary.csv"));
}

TEST_CASE("a --jobs below 1 is bad input, in one readable line", "[sweep]") {
  Sandbox box;
  box.write("base.toml", test::kTinyBaseToml);
  box.write("tiny.toml", kTiny);
  const auto before = box.snapshot();
  const auto r = box.run({"sweep", "tiny.toml", "--jobs", "0"});
  CHECK(r.code == 2);
  CHECK(r.err == "error: --jobs: Value 0 not in range 1 to 4096 (see stickslip sweep --help)\n");
  CHECK(box.snapshot() == before);
}
