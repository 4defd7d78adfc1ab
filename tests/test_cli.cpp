// The command line, run as a real process: exit codes, one-line error messages
// (file:line: section.key: what), and that bad input writes nothing at all.
#include <catch2/catch.hpp>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "sandbox.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "stickslip/output/recorder.hpp"

namespace fs = std::filesystem;
using Catch::Contains;
using Catch::StartsWith;

using namespace stickslip::test;

namespace {

const std::string kTiny =
    "[lattice]\nnx = 3\nny = 3\nnz = 2\n"
    "[interface]\ncontacts = [{ site = [1, 1], v_star = 1e-2 }]\n"
    "[run]\nt_end = 2e-5\naverage_from = 1e-5\n"
    "[output]\ninterval = 1e-6\ntraces = \"all\"\n";

// Runs `case_text` as bad.toml (or `case_name` if given, without writing it)
// with --out and `extra`; checks it is refused as bad input: exit 2, one line on
// stderr, nothing on stdout, nothing written. Returns the stderr text and the
// case path as passed to the program.
std::pair<std::string, std::string> refused(const std::string& case_text,
                                            const std::vector<std::string>& extra = {},
                                            const char* case_name = nullptr) {
  Sandbox box;
  const fs::path file = case_name ? box.work / case_name : box.write("bad.toml", case_text);
  const fs::path out = box.work / "out_dir";
  std::vector<std::string> args{"run", file.string(), "--out", out.string(), "--quiet"};
  args.insert(args.end(), extra.begin(), extra.end());
  const auto before = box.snapshot();
  const Result r = box.run(args);
  INFO("stderr: " << r.err);
  CHECK(r.code == 2);
  CHECK(lines(r.err) == 1);
  CHECK((!r.err.empty() && r.err.back() == '\n'));
  CHECK(r.out.empty());
  CHECK_FALSE(fs::exists(out));
  CHECK(box.snapshot() == before);
  return {r.err, file.string()};
}

}  // namespace

TEST_CASE("malformed TOML is bad input, blamed on its line", "[cli]") {
  const auto [err, file] = refused("[lattice]\nnx = 3\nny = = 3\n");
  CHECK_THAT(err, StartsWith("error: " + file + ":3: malformed TOML: "));
}

TEST_CASE("an unknown key is bad input, and the nearest key is suggested", "[cli]") {
  const auto [err, file] = refused("[lattice]\nnx = 3\n[interface]\ncoverag = 0.5\n");
  CHECK_THAT(err, StartsWith("error: " + file + ":4: interface.coverag: unknown key 'coverag'"));
  CHECK_THAT(err, Contains("did you mean 'coverage'?"));
}

TEST_CASE("a value of the wrong type is bad input", "[cli]") {
  {
    const auto [err, file] = refused("[lattice]\nnx = \"3\"\n");
    CHECK(err == "error: " + file + ":2: lattice.nx: expected an integer, got string\n");
  }
  {
    const auto [err, file] = refused("[lattice]\nnx = 3\n\n[interface]\ncoverage = \"half\"\n");
    CHECK(err == "error: " + file + ":5: interface.coverage: expected a number, got string\n");
  }
}

TEST_CASE("an out-of-range value is bad input, blamed on its line and key", "[cli]") {
  struct Bad {
    std::string text, where, what;
  };
  for (const Bad& b : std::vector<Bad>{
           {"[lattice]\nnx = 3\n[interface]\ncoverage = 1.5\n",
            ":4: interface.coverage: ", "must be in (0, 1], got 1.5"},
           {"[lattice]\nnx = 3\nnz = 1\n", ":3: lattice.nz: ", "must be >= 2, got 1"},
           {"[lattice]\n\n\nspacing = -1e-6\n", ":4: lattice.spacing: ", "must be > 0, got -1e-06"},
       }) {
    INFO(b.text);
    const auto [err, file] = refused(b.text);
    CHECK(err == "error: " + file + b.where + b.what + "\n");
  }
}

TEST_CASE("an out-of-range value from --set value is bad input, blamed on --set and the key",
          "[cli]") {
  {
    const auto [err, file] = refused(kTiny, {"--set", "interface.coverage=1.5"});
    CHECK(err == "error: --set interface.coverage: must be in (0, 1], got 1.5\n");
  }
  {
    const auto [err, file] = refused(kTiny, {"--set", "lattice.nz=1"});
    CHECK(err == "error: --set lattice.nz: must be >= 2, got 1\n");
  }
}

TEST_CASE("a missing case file is bad input", "[cli]") {
  const auto [err, file] = refused("", {}, "no_such_case.toml");
  CHECK(err == "error: " + file + ": cannot read case file: No such file or directory\n");
}

TEST_CASE("an output directory holding results is refused without --overwrite", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const fs::path out = box.work / "results";
  fs::create_directories(out);
  spit(out / "summary.json", "results of an earlier run\n");
  const auto before = box.snapshot();
  const Result r = box.run({"run", file.string(), "--out", out.string(), "--quiet"});
  INFO("stderr: " << r.err);
  CHECK(r.code == 2);
  CHECK(lines(r.err) == 1);
  CHECK_THAT(r.err, StartsWith("error: " + out.string() + ": "));
  CHECK_THAT(r.err, Contains("pass --overwrite to replace them"));
  CHECK_THAT(r.err, !Contains("Python"));  // the command line speaks its own language only
  CHECK(r.out.empty());
  CHECK(slurp(out / "summary.json") == "results of an earlier run\n");
  CHECK(box.snapshot() == before);

  // A bad case with --overwrite is refused before the directory is touched.
  const Result bad = box.run({"run", file.string(), "--out", out.string(), "--quiet", "--overwrite",
                              "--set", "lattice.nz=1"});
  CHECK(bad.code == 2);
  CHECK(bad.err == "error: --set lattice.nz: must be >= 2, got 1\n");
  CHECK(box.snapshot() == before);
}

TEST_CASE("an empty --out is bad input, not the default directory", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const auto before = box.snapshot();
  const Result r = box.run({"run", file.string(), "--out", "", "--quiet"});
  CHECK(r.code == 2);
  CHECK(r.err == "error: --out: an empty path; name a directory (see stickslip run --help)\n");
  CHECK(box.snapshot() == before);  // out/tiny was not written
  CHECK(box.run({"sweep", file.string(), "--out", ""}).code == 2);
  CHECK(box.snapshot() == before);
}

TEST_CASE("an unknown command-line option is bad input", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const fs::path out = box.work / "results";
  const auto before = box.snapshot();
  const Result r = box.run({"run", file.string(), "--out", out.string(), "--bogus"});
  INFO("stderr: " << r.err);
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Contains("--bogus"));
  CHECK(r.out.empty());
  CHECK_FALSE(fs::exists(out));
  CHECK(box.snapshot() == before);
}

// Bad options are bad input like any other: one line, exit 2 (CLI11's own
// report would be two lines).
TEST_CASE("an unknown command-line option is reported in one line", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const Result r = box.run({"run", file.string(), "--bogus"});
  INFO("stderr: " << r.err);
  CHECK(r.code == 2);
  CHECK(lines(r.err) == 1);
}

TEST_CASE("a misspelt option or command names the nearest one and the subcommand's help", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const auto before = box.snapshot();
  // CLI11 alone says "The following arguments were not expected: 1 --thread"
  // and points to the program's help, not the subcommand's.
  const Result thread = box.run({"run", file.string(), "--thread", "1"});
  CHECK(thread.code == 2);
  CHECK(thread.err ==
        "error: unknown option '--thread' (did you mean '--threads'?) (see stickslip run "
        "--help)\n");
  const Result jobs = box.run({"sweep", file.string(), "--job", "2"});
  CHECK(jobs.code == 2);
  CHECK_THAT(jobs.err, Contains("(did you mean '--jobs'?) (see stickslip sweep --help)"));
  // A swap of two letters is one typo; CLI11 alone: "A subcommand is required".
  const Result command = box.run({"rnu", file.string()});
  CHECK(command.code == 2);
  CHECK(command.err ==
        "error: unknown command 'rnu' (did you mean 'run'?) (see stickslip --help)\n");
  const Result none = box.run({});
  CHECK(none.code == 2);
  CHECK_THAT(none.err, Contains("a command is required (valid: run, compare, sweep, keys)"));
  CHECK(box.snapshot() == before);
}

namespace {

// The version project() gives in CMakeLists.txt, the one place it is set.
std::string project_version() {
  std::smatch m;
  const std::string cmake = slurp(fs::path(STICKSLIP_SOURCE_DIR) / "CMakeLists.txt");
  REQUIRE(std::regex_search(cmake, m, std::regex(R"(project\(stickslip VERSION (\S+) )")));
  return m[1].str();
}

}  // namespace

TEST_CASE("stickslip --version prints the version and the git commit, exit 0", "[cli]") {
  Sandbox box;
  const Result r = box.run({"--version"});
  INFO("stdout: " << r.out << "stderr: " << r.err);
  CHECK(r.code == 0);
  CHECK(r.err.empty());
  std::smatch m;
  REQUIRE(std::regex_match(
      r.out, m,
      std::regex(R"(stickslip (\S+) \(git commit ([0-9a-f]{40}(-modified)?|unknown)\)\n)")));
  CHECK(m[1].str() == project_version());
  // The commit of the source tree the program was built from.
  const fs::path head = box.root / "head";
  if (std::system(("git -C " + quote(STICKSLIP_SOURCE_DIR) + " rev-parse HEAD >" +
                   quote(head.string()) + " 2>/dev/null")
                      .c_str()) == 0)
    CHECK(m[2].str().substr(0, 40) == slurp(head).substr(0, 40));
}

TEST_CASE("CITATION.cff cites the version the program is", "[cli]") {
  const std::string cff = slurp(fs::path(STICKSLIP_SOURCE_DIR) / "CITATION.cff");
  CHECK_THAT(cff, StartsWith("cff-version: 1.2.0\n"));
  CHECK_THAT(cff, Contains("\nversion: \"" + project_version() + "\"\n"));
}

TEST_CASE("a tiny case runs and writes its outputs, a rerun needs --overwrite", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const fs::path out = box.work / "results";
  const std::vector<std::string> args{"run", file.string(), "--out", out.string(), "--quiet"};

  const Result r = box.run(args);
  INFO("stdout: " << r.out << "stderr: " << r.err);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.out, StartsWith("mu = "));
  // 20 µs from rest is the elastic loading, no slip: μ is flagged as no friction coefficient.
  CHECK(lines(r.err) == 1);
  CHECK_THAT(r.err, StartsWith("warning: mu is not a friction coefficient: in the averaging "
                               "window [1e-05, 2e-05] s F_f rises as a ramp"));

  REQUIRE(fs::exists(out / "summary.json"));
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  CHECK(summary.at("mu").is_number());
  CHECK(summary.at("contacts") == 1);
  CHECK(summary.at("regime").at("kind") == "loading");
  CHECK(summary.at("regime").at("mu_trusted") == false);

  const std::string friction = slurp(out / "friction.csv");
  CHECK_THAT(friction, StartsWith("t,F_f,mu_inst\n"));
  CHECK(lines(friction) == 1 + 21);  // header, t = 0, and one row per 1e-6 s up to 2e-5 s
  CHECK_THAT(friction, Contains("\n0,"));

  const std::string contacts = slurp(out / "contacts.csv");
  CHECK(lines(contacts) == 2);
  CHECK_THAT(contacts, Contains("\n0,1,1,"));

  const std::string traces = slurp(out / "traces.csv");
  CHECK_THAT(traces, StartsWith("t,vx_0,vy_0\n"));
  CHECK(lines(traces) == 1 + 21);

  // Again, without --overwrite: refused, and nothing changes.
  const auto before = box.snapshot();
  const Result again = box.run(args);
  CHECK(again.code == 2);
  CHECK(lines(again.err) == 1);
  CHECK_THAT(again.err, Contains("--overwrite"));
  CHECK(box.snapshot() == before);

  // With --overwrite: the results are replaced.
  spit(out / "summary.json", "stale\n");
  auto args_overwrite = args;
  args_overwrite.push_back("--overwrite");
  const Result replaced = box.run(args_overwrite);
  CHECK(replaced.code == 0);
  CHECK_THAT(replaced.out, StartsWith("mu = "));
  CHECK(nlohmann::json::parse(slurp(out / "summary.json")).at("mu") == summary.at("mu"));
  CHECK(slurp(out / "friction.csv") == friction);
}

// A summary.json that is a directory cannot be replaced, even with --overwrite:
// refused up front (exit 2) rather than failing at the end of the run.
TEST_CASE("an output directory whose summary.json is a directory is bad input", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const fs::path out = box.work / "results";
  fs::create_directories(out / "summary.json");
  spit(out / "summary.json" / "keep", "x\n");
  const auto before = box.snapshot();
  const Result r = box.run({"run", file.string(), "--out", out.string(), "--quiet", "--overwrite"});
  INFO("stderr: " << r.err);
  CHECK(r.code == 2);
  CHECK(lines(r.err) == 1);
  CHECK(box.snapshot() == before);
}

// Every file any output may write marks a directory as holding results, and
// --overwrite removes each one, also those the new run does not write (no
// stale steps.csv or signals.csv next to the new results).
TEST_CASE("a rerun with --overwrite leaves no stale output of any kind", "[cli]") {
  Sandbox box;
  const fs::path file = box.write("tiny.toml", kTiny);
  const fs::path out = box.work / "results";
  const auto files = stickslip::recorder_files();
  REQUIRE(files.size() >= 7);
  for (const std::string& name : files) {
    INFO(name);
    fs::remove_all(out);
    fs::create_directories(out);
    spit(out / name, "stale\n");
    const Result refused = box.run({"run", file.string(), "--out", out.string(), "--quiet"});
    CHECK(refused.code == 2);
    CHECK_THAT(refused.err, Contains(name) && Contains("--overwrite"));
    const Result r =
        box.run({"run", file.string(), "--out", out.string(), "--quiet", "--overwrite"});
    REQUIRE(r.code == 0);
    CHECK((!fs::exists(out / name) || slurp(out / name) != "stale\n"));
  }
}

TEST_CASE(
    "a run gives the same files on 1 and 2 threads, says how many it used, and continues on "
    "either",
    "[cli][threads]") {
  Sandbox box;
  // 50 contacts on 10×10×3 under dirk: the contacts' coupled solve with its
  // LU, the lattice's modes and the contacts' stages all split over threads.
  const fs::path file = box.write("many.toml",
                                  "[lattice]\nnx = 10\nny = 10\nnz = 3\n"
                                  "[interface]\ncoverage = 0.5\nseed = 4\n"
                                  "[run]\nt_end = 1e-4\naverage_from = 2e-5\n"
                                  "[solver]\nmethod = \"dirk\"\nrtol = 1e-5\n"
                                  "[output]\ninterval = 2e-6\ntraces = \"all\"\n");
  std::vector<nlohmann::json> summaries;
  for (const char* threads : {"1", "2"}) {
    const fs::path out = box.work / (std::string("threads_") + threads);
    const Result r =
        box.run({"run", file.string(), "--out", out.string(), "--quiet", "--threads", threads});
    INFO("stderr: " << r.err);
    REQUIRE(r.code == 0);
    summaries.push_back(nlohmann::json::parse(slurp(out / "summary.json")));
    CHECK(summaries.back()["solver"]["threads"] == std::stoi(threads));
  }
  CHECK(summaries[0]["contacts"].get<int>() > 40);
  CHECK(summaries[0]["solver_stats"]["newton_iterations"].get<long>() > 0);
  CHECK(summaries[0]["solver_stats"] == summaries[1]["solver_stats"]);
  CHECK(summaries[0]["mu"] == summaries[1]["mu"]);
  CHECK(summaries[0]["energy_residual"] == summaries[1]["energy_residual"]);
  for (const char* table : {"friction.csv", "traces.csv", "events.csv"})
    CHECK(slurp(box.work / "threads_1" / table) == slurp(box.work / "threads_2" / table));

  // The thread count is no part of what a restart must match.
  const stickslip::Case then = stickslip::read_case(file.string(), {"solver.threads=2"});
  const stickslip::Case now = stickslip::read_case(file.string(), {"solver.threads=1"});
  CHECK(stickslip::same_case(stickslip::to_json(then), now));
  const stickslip::Case other = stickslip::read_case(file.string(), {"solver.rtol=1e-6"});
  CHECK_FALSE(stickslip::same_case(stickslip::to_json(then), other));
}

TEST_CASE("a negative thread count is bad input, from the command line or the case", "[cli]") {
  const auto [flag, flag_file] = refused(kTiny, {"--threads", "-2"});
  CHECK_THAT(flag, StartsWith("error: --threads: "));
  CHECK_THAT(flag, Contains("-2"));
  const auto [key, key_file] = refused(kTiny + "[solver]\nthreads = -1\n");
  CHECK_THAT(key, StartsWith("error: " + key_file + ":"));
  CHECK_THAT(key, Contains("solver.threads: must be >= 0, got -1"));
}
