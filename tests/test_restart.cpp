// Checkpoint and restart through the real binary: a run stopped by SIGTERM and
// restarted agrees with an uninterrupted one, without gaps or duplicated rows,
// in either output format; a restart with another case is refused, naming
// what differs; the command an interrupted run prints continues it from any
// directory; a finished run that kept its final state continues to a later
// t_end as if it had run there straight; and each start and each refusal of
// restart admission (plan_output_dir) on the directories a run leaves.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "sandbox.hpp"
#include "stickslip/analysis/compare.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/integrate/errors.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "stickslip/output/recorder.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/tables.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/run/resume.hpp"
#include "stickslip/run/run.hpp"
#include "stickslip/run/run_lock.hpp"
#include "stickslip/version.hpp"
#include "temp_dir.hpp"
#include "test_cases.hpp"

namespace fs = std::filesystem;
using namespace stickslip;

namespace {

int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<double> first_column(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<double> t;
  while (std::getline(in, line)) t.push_back(std::strtod(line.c_str(), nullptr));
  return t;
}

const std::string kCase = std::string(stickslip::test::kTwoContactToml) + R"([run]
t_end = 1.5e-3
average_from = 5e-4
checkpoint_every = 2e-4
[solver]
method = "imex"  # seconds, not the fraction of one dirk takes: a signal lands mid-run
rtol = 1e-7
atol_displacement = 1e-13
atol_velocity = 1e-8
[output]
interval = 1e-6
traces = "all"
signals = true
steps = true
)";

std::vector<double> times(const fs::path& dir, const std::string& table) {
  return read_run_table(dir, table).t;
}

}  // namespace

TEST_CASE("a run stopped by SIGTERM and restarted agrees with an uninterrupted one",
          "[slow][restart]") {
  const std::string format = GENERATE("csv", "hdf5");
  INFO("[output] format = " << format);
  const test::TempDir tmp("stickslip_test_restart_" + format);
  const fs::path& box = tmp.path;
  std::ofstream(box / "two.toml") << kCase << "format = \"" << format << "\"\n";
  const std::string exe = STICKSLIP_EXE, dir = box.string();

  REQUIRE(shell("cd " + dir + " && " + exe + " run two.toml --out full --quiet >/dev/null") == 0);
  CHECK(fs::exists(box / "full" / kHdf5File) == (format == "hdf5"));
  CHECK(fs::exists(box / "full" / "friction.csv") == (format == "csv"));
  CHECK_FALSE(fs::exists(box / "full" / "checkpoint.bin"));  // removed once finished

  // Stop it as soon as it has written a checkpoint.
  const int stopped = shell("cd " + dir + " && (" + exe +
                            " run two.toml --out part --quiet >/dev/null 2>stop.txt & pid=$!; "
                            "while [ ! -f part/checkpoint.bin ]; do sleep 0.02; done; "
                            "kill -TERM $pid; wait $pid)");
  REQUIRE(stopped == 143);
  std::ifstream note(box / "stop.txt");
  const std::string message((std::istreambuf_iterator<char>(note)), {});
  CHECK_THAT(message, Catch::Contains("--restart " + (box / "part").string()));
  CHECK_FALSE(fs::exists(box / "part" / "summary.json"));

  // A different case may not continue it.
  CHECK(shell("cd " + dir + " && " + exe +
              " run two.toml --restart part --quiet --set drive.velocity=2e-3 2>/dev/null") == 2);

  // A run's wall time spans its attempts, like its step counts: the restart
  // adds its own to the checkpoint's (set here to stand for a long first attempt).
  Checkpoint checkpoint = read_checkpoint(box / "part");
  CHECK(checkpoint.wall_seconds > 0);
  checkpoint.wall_seconds = 1000;
  write_checkpoint(box / "part", checkpoint);
  const auto restart_began = std::chrono::steady_clock::now();
  REQUIRE(shell("cd " + dir + " && " + exe + " run two.toml --restart part --quiet >/dev/null") ==
          0);
  const std::chrono::duration<double> restart_took =
      std::chrono::steady_clock::now() - restart_began;
  const auto summary = read_summary(box / "part");
  REQUIRE(summary);
  CHECK(summary->wall_seconds >= 1000);
  CHECK(summary->wall_seconds <= 1000 + restart_took.count());
  const auto full_t = times(box / "full", "friction");
  CHECK(full_t.size() == 1501);
  CHECK(times(box / "part", "friction") == full_t);  // same rows: no gap, no duplicate
  CHECK(times(box / "part", "traces") == full_t);

  // Restarting changes the step sequence, so the runs agree to the
  // integration tolerance, not bit for bit. Each slip's onset amplifies state
  // differences, and where the stop falls depends on timing: at rtol 1e-6
  // over 3 ms the events shifted by 1e-8–4e-8 s, which on the steep slip
  // fronts (0.16 m/s within ~1 µs) moves traces by 1–2.5 % in L2 — a margin
  // that depended on the machine's load. At rtol 1e-7 over 1.5 ms (four slips
  // of contact 0) events shift by < 1e-9 s and traces by < 1e-3.
  const CompareResult r = compare_runs(box / "full", box / "part", 2e-2);
  INFO(to_json(r).dump(1));
  CHECK(r.pass());
  CHECK(r.mu_rel_diff < 1e-5);
  for (const auto& e : r.events) CHECK(e.max_dt < 1e-7);  // 1/30 of a slip's duration

  // The signals continue across the restart: the same rows, and the acoustic
  // signal (a second difference over output times) defined on every row after
  // the first two, with the two rows before the restart read back.
  const TraceTable full_s = read_run_table(box / "full", "signals");
  const TraceTable part_s = read_run_table(box / "part", "signals");
  REQUIRE(part_s.columns ==
          std::vector<std::string>{"block_velocity", "contact_impulse", "acoustic"});
  REQUIRE(part_s.t == full_s.t);
  const auto& full_acoustic = full_s.values[2];
  const auto& part_acoustic = part_s.values[2];
  double largest = 0, worst = 0;
  for (std::size_t k = 2; k < full_s.t.size(); ++k) {
    REQUIRE(std::isfinite(part_acoustic[k]));
    largest = std::max(largest, std::abs(full_acoustic[k]));
    worst = std::max(worst, std::abs(part_acoustic[k] - full_acoustic[k]));
  }
  // Slips shift by < 1e-9 s, 1/1000 of the output interval the signal is
  // differenced over.
  INFO("largest acoustic " << largest << ", largest difference " << worst);
  CHECK(worst < 1e-2 * largest);

  // Every table continues across the restart without a duplicated row or a
  // step back in time (each recorder cuts its own table back to the
  // checkpoint; reading a table checks that its times increase); the case
  // asks for all that a restart continues.
  for (const char* table : {"friction", "traces", "steps", "signals"}) {
    INFO(table);
    CHECK(times(box / "part", table).size() > 10);
  }
  const auto events = read_run_events(box / "part");
  CHECK(events.size() > 10);
  for (std::size_t k = 1; k < events.size(); ++k) {
    CHECK(events[k].t >= events[k - 1].t);
    CHECK_FALSE((events[k].t == events[k - 1].t && events[k].contact == events[k - 1].contact));
  }
}

TEST_CASE("a multirate run stopped by SIGTERM and restarted agrees with an uninterrupted one",
          "[slow][restart][multirate]") {
  // The stepper starts from a state (its first a_c the law's, as dirk's first
  // f is ARKStep's), so a checkpoint is all a restart needs; the step
  // sequence changes, so the runs agree to the tolerance, as imex's above.
  const test::TempDir tmp("stickslip_test_restart_multirate");
  const fs::path& box = tmp.path;
  std::ofstream(box / "two.toml") << kCase;
  const std::string exe = STICKSLIP_EXE, dir = box.string();
  // kCase's absolute tolerances are imex's; multirate gets rtol's own
  // (integrate/tolerances.hpp), which keep it running (~3 s) long enough for
  // the stop to land mid-run.
  const std::string run = exe +
                          " run two.toml --set 'solver.method=\"multirate\"'"
                          " --set solver.multirate_min_fast=1"
                          " --set solver.atol_velocity=4.75e-12"
                          " --set solver.atol_displacement=1.95e-14 --quiet ";
  const std::string in_box = "cd " + dir + " && ";
  REQUIRE(shell(in_box + run + "--out full >/dev/null") == 0);
  // (The wait ends if the run does: then its exit code is 0, not 143.)
  REQUIRE(shell(in_box + "(" + run +
                "--out part >/dev/null 2>&1 & pid=$!; "
                "while kill -0 $pid 2>/dev/null && [ ! -f part/checkpoint.bin ]; do sleep 0.02; "
                "done; kill -TERM $pid; wait $pid)") == 143);
  REQUIRE(shell(in_box + run + "--restart part >/dev/null") == 0);
  CHECK(times(box / "part", "friction") == times(box / "full", "friction"));
  CHECK(read_run_table(box / "part", "steps").columns ==
        read_run_table(box / "full", "steps").columns);
  const CompareResult r = compare_runs(box / "full", box / "part", 2e-2);
  INFO(to_json(r).dump(1));
  CHECK(r.pass());
  CHECK(r.mu_rel_diff < 1e-5);
  for (const auto& e : r.events) CHECK(e.max_dt < 1e-7);  // 1/30 of a slip's duration
}

TEST_CASE("SIGTERM inside a long output interval stops the run at once and it restarts",
          "[slow][restart]") {
  const test::TempDir tmp("stickslip_test_restart_mid");
  const fs::path& box = tmp.path;
  // One output row at the end: before, the run answered a signal only there.
  std::ofstream(box / "two.toml") << kCase;
  const std::string exe = STICKSLIP_EXE, dir = box.string();
  const std::string sets = " --set output.interval=3e-3 --set run.checkpoint_every=0";

  REQUIRE(shell("cd " + dir + " && " + exe + " run two.toml --out full --quiet" + sets +
                " >/dev/null") == 0);
  const int stopped =
      shell("cd " + dir + " && (" + exe + " run two.toml --out part --quiet" + sets +
            " >/dev/null 2>stop.txt & pid=$!; "
            "while [ ! -f part/friction.csv ]; do sleep 0.02; done; sleep 0.3; "
            "kill -TERM $pid; wait $pid)");
  REQUIRE(stopped == 143);
  std::ifstream note(box / "stop.txt");
  const std::string message((std::istreambuf_iterator<char>(note)), {});
  INFO(message);
  const auto at = message.find("interrupted at t = ");
  REQUIRE(at != std::string::npos);
  const double t_stop = std::strtod(message.c_str() + at + 19, nullptr);
  CHECK(t_stop > 0.0);
  CHECK(t_stop < 3e-3);  // mid-interval, not at the only output time
  CHECK(fs::exists(box / "part" / "checkpoint.bin"));
  CHECK(first_column(box / "part" / "friction.csv") == std::vector<double>{0.0});

  REQUIRE(shell("cd " + dir + " && " + exe + " run two.toml --restart part --quiet" + sets +
                " >/dev/null") == 0);
  CHECK(first_column(box / "part" / "friction.csv") == first_column(box / "full" / "friction.csv"));
  const CompareResult r = compare_runs(box / "full", box / "part", 2e-2);
  INFO(to_json(r).dump(1));
  CHECK(r.mu_rel_diff < 1e-5);
  for (const auto& e : r.events) CHECK(e.max_dt < 1e-7);
}

TEST_CASE("a restart drops a row cut off mid-write by a killed run", "[restart]") {
  const test::TempDir tmp("stickslip_test_cut_row");
  const fs::path file = tmp.path / "cut_row.csv";
  // The last row lost its newline and the end of its time (0.00012 -> 0.0).
  std::ofstream(file) << "t,F_f\n0,0\n1e-05,2.5\n2e-05,5.25\n0.0";
  keep_rows_up_to(file, 1e-4);
  CHECK(first_column(file) == std::vector<double>{0.0, 1e-5, 2e-5});
}

namespace {

const char* kTiny = R"([lattice]
nx = 4
ny = 4
nz = 3
[interface]
contacts = [ { site = [1, 2], v_star = 4.75e-4 } ]
[run]
t_end = 2e-5
average_from = 1e-5
)";

// Runs `c` into `dir` and stops it at its first output time, as SIGTERM from
// outside would: a checkpoint is left there.
void interrupt(const Case& c, const RunOptions& options) {
  const ScopedStopHandlers handlers;
  std::raise(SIGTERM);
  REQUIRE_THROWS_AS(run_case(c, options), Interrupted);
  REQUIRE(fs::exists(options.out_dir / kCheckpointFile));
}

}  // namespace

TEST_CASE("a run stops when RunOptions::stop_signal asks, no handler or signal needed",
          "[restart]") {
  const test::TempDir tmp("stickslip_test_restart_stop_option");
  const Case c = parse_case(kTiny, tmp.path / "tiny.toml");
  RunOptions options{.out_dir = tmp.path / "run", .quiet = true};
  options.stop_signal = [] { return SIGTERM; };
  try {
    run_case(c, options);
    FAIL("the run did not stop");
  } catch (const Interrupted& stopped) {
    CHECK(stopped.signal == SIGTERM);
    CHECK(stopped.t < c.run.t_end);
  }
  REQUIRE(fs::exists(options.out_dir / kCheckpointFile));
  options.stop_signal = nullptr;
  options.restart = true;
  CHECK(run_case(c, options).t_end == 2e-5);
}

TEST_CASE("a restart continues a run whose summary.json is cut short, a whole one is refused",
          "[restart]") {
  const test::TempDir tmp("stickslip_test_restart_cut_summary");
  const Case c = parse_case(kTiny, tmp.path / "tiny.toml");
  RunOptions options{.out_dir = tmp.path / "run", .quiet = true};
  interrupt(c, options);
  options.restart = true;
  // Whole JSON but not a summary this code writes: not restarted over.
  std::ofstream(options.out_dir / kSummaryFile) << "{}";
  CHECK_THROWS_WITH(run_case(c, options),
                    Catch::Contains("has finished") && Catch::Contains("another code version?"));
  std::ofstream(options.out_dir / kSummaryFile) << R"({"mu": 1.)";  // not JSON: no finished run
  const Summary finished = run_case(c, options);
  CHECK(finished.t_end == 2e-5);
  CHECK(read_summary(options.out_dir));
  CHECK_THROWS_WITH(run_case(c, options), Catch::Contains("has finished"));
}

TEST_CASE("a checkpoint of another code version continues only when asked, and says so",
          "[restart]") {
  const test::TempDir tmp("stickslip_test_restart_any_version");
  const Case c = parse_case(kTiny, tmp.path / "tiny.toml");
  RunOptions options{.out_dir = tmp.path / "run", .quiet = true};
  interrupt(c, options);
  Checkpoint older = read_checkpoint(options.out_dir);
  REQUIRE(older.segments.size() == 1);
  CHECK(older.segments[0].git_commit == kGitCommit);
  older.git_commit = older.segments[0].git_commit = "0000000";
  write_checkpoint(options.out_dir, older);

  options.restart = true;
  CHECK_THROWS_WITH(run_case(c, options),
                    Catch::Contains("code version 0000000") && Catch::Contains("--any-version"));
  options.any_version = true;
  const Summary s = run_case(c, options);
  REQUIRE(s.segments.size() == 2);
  CHECK(s.segments[0].from == 0.0);
  CHECK(s.segments[0].git_commit == "0000000");
  CHECK(s.segments[1].from == older.t);
  CHECK(s.segments[1].git_commit == kGitCommit);
  const auto written = read_summary(options.out_dir);
  REQUIRE(written);
  CHECK(written->segments.size() == 2);
  CHECK(written->segments[0].git_commit == "0000000");
}

TEST_CASE("solver statistics written before krylov_iterations existed read back with it zero",
          "[restart]") {
  // A checkpoint's or summary's statistics from before the field: the rest
  // read back as written, the missing count as none, and sums still add.
  const nlohmann::json older = {
      {"steps", 581},          {"step_attempts", 674},         {"rhs_explicit", 0},
      {"rhs_implicit", 680},   {"newton_iterations", 35234},   {"convergence_failures", 78},
      {"linear_setups", 235},  {"jacobian_evaluations", 3068}, {"error_test_failures", 15},
      {"root_evaluations", 0}, {"last_step", 2.6e-6}};
  SolverStats s = older.get<SolverStats>();
  CHECK(s.steps == 581);
  CHECK(s.jacobian_evaluations == 3068);
  CHECK(s.krylov_iterations == 0);
  SolverStats later;
  later.krylov_iterations = 22723;
  later.steps = 10;
  s += later;
  CHECK(s.krylov_iterations == 22723);
  CHECK(s.steps == 591);
  CHECK(nlohmann::json(s).at("krylov_iterations") == 22723);
}

namespace {

// The command after "continue with: " in a run's messages ("" if none).
std::string continue_line(const std::string& messages) {
  const std::string tag = "continue with: ";
  const auto at = messages.find(tag);
  if (at == std::string::npos) return "";
  const auto from = at + tag.size();
  return messages.substr(from, messages.find('\n', from) - from);
}

// Runs `command` with /bin/sh in `cwd`; its stderr in `err`.
int shell_in(const fs::path& cwd, const std::string& command, const fs::path& err) {
  return shell("cd " + test::quote(cwd.string()) + " && " + command + " >/dev/null 2>" +
               test::quote(err.string()));
}

// `command` started in the background in `cwd`, stopped by SIGINT to it alone
// once `file` (relative to `cwd`) is newer than the marker made just before
// (so an earlier checkpoint does not count); its exit code.
int interrupt_when_written(const fs::path& cwd, const std::string& command, const std::string& file,
                           const fs::path& err) {
  return shell("cd " + test::quote(cwd.string()) + " && touch .marker && sleep 0.01 && (" +
               command + " >/dev/null 2>" + test::quote(err.string()) +
               " & pid=$!; while kill -0 $pid 2>/dev/null && [ ! " + test::quote(file) +
               " -nt .marker ]; do sleep 0.02; done; kill -INT $pid; wait $pid)");
}

}  // namespace

TEST_CASE("the command an interrupted run prints continues it as given from any directory",
          "[slow][restart]") {
  // Paths with spaces, the program by a relative path, a --set that the
  // checkpoint's case holds (without it a restart is refused), --threads, and
  // --any-version once a checkpoint of another code version needs it.
  const test::TempDir tmp("stickslip_test_continue_line");
  const fs::path here = tmp.path / "runs here", elsewhere = tmp.path / "else where";
  fs::create_directories(here);
  fs::create_directories(elsewhere);
  std::ofstream(here / "my case.toml") << kCase;
  const std::string program = fs::relative(STICKSLIP_EXE, here).string();
  REQUIRE(program.find('/') != std::string::npos);
  const std::string first = test::quote(program) +
                            " run 'my case.toml' --out 'part dir' --set run.average_from=6e-4"
                            " --threads 1 --quiet";
  REQUIRE(interrupt_when_written(here, first, "part dir/checkpoint.bin", tmp.path / "stop1.txt") ==
          130);
  const std::string stop1 = test::slurp(tmp.path / "stop1.txt");
  INFO(stop1);
  const std::string line1 = continue_line(stop1);
  REQUIRE_FALSE(line1.empty());
  CHECK_THAT(line1, !Catch::Contains("--overwrite") && !Catch::Contains("--out"));

  // Started again as at first: refused, pointing at --restart and the same
  // command, and nothing in the directory changes.
  const auto checkpoint_before = test::slurp(here / "part dir" / kCheckpointFile);
  const auto friction_before = test::slurp(here / "part dir" / "friction.csv");
  REQUIRE(shell_in(here, first, tmp.path / "again.txt") == 2);
  const std::string again = test::slurp(tmp.path / "again.txt");
  CHECK_THAT(again, Catch::Contains("interrupted run") && Catch::Contains("--restart"));
  CHECK(continue_line(again) == line1);
  CHECK(test::slurp(here / "part dir" / kCheckpointFile) == checkpoint_before);
  CHECK(test::slurp(here / "part dir" / "friction.csv") == friction_before);

  // The line, from another directory, continues the run; stopped again, its
  // own line keeps --any-version, which the checkpoint needs once more.
  auto stamp_other_version = [&] {
    Checkpoint c = read_checkpoint(here / "part dir");
    c.git_commit = "0000000";
    write_checkpoint(here / "part dir", c);
  };
  stamp_other_version();
  REQUIRE(shell_in(elsewhere, line1, tmp.path / "refused.txt") == 2);  // another version's
  CHECK_THAT(test::slurp(tmp.path / "refused.txt"), Catch::Contains("--any-version"));
  REQUIRE(interrupt_when_written(elsewhere, line1 + " --any-version",
                                 (here / "part dir" / kCheckpointFile).string(),
                                 tmp.path / "stop2.txt") == 130);
  const std::string line2 = continue_line(test::slurp(tmp.path / "stop2.txt"));
  INFO(test::slurp(tmp.path / "stop2.txt"));
  REQUIRE_FALSE(line2.empty());
  stamp_other_version();
  REQUIRE(shell_in(elsewhere, line2, tmp.path / "end.txt") == 0);

  const auto summary = read_summary(here / "part dir");
  REQUIRE(summary);
  CHECK(summary->case_json["run"]["average_from"] == 6e-4);  // the --set, carried
  CHECK(summary->solver["threads"] == 1);
  CHECK(summary->segments.size() == 3);
  const auto t = times(here / "part dir", "friction");
  REQUIRE(t.size() == 1501);  // every output time once: no gap, no duplicate
  for (std::size_t k = 0; k < t.size(); ++k) CHECK(t[k] == Approx(1e-6 * double(k)));
}

namespace {

// A fresh start's refusal by plan_output_dir, if it gave one.
std::optional<ResumableRunError> refusal_of(const Case& c, const DirectoryRequest& request) {
  try {
    plan_output_dir(c, request);
  } catch (const ResumableRunError& e) {
    return e;
  }
  return std::nullopt;
}

}  // namespace

TEST_CASE("plan_output_dir decides each start and each refusal, reading the directory only",
          "[restart]") {
  // Every way the directory and the request meet, without running anything:
  // the checkpoints and summaries are written as a run would leave them.
  test::Sandbox box("stickslip_plan_");
  const Case c = parse_case(kTiny, box.work / "tiny.toml");  // t_end = 2e-5
  const fs::path dir = box.work / "run";
  fs::create_directories(dir);
  auto ending_at = [&](double t_end) {
    Case k = c;
    k.run.t_end = t_end;
    return k;
  };
  auto checkpoint_at = [&](double t, const std::string& commit) {
    Checkpoint k;
    k.t = t;
    k.output_index = 10;
    k.case_json = to_json(c);
    k.git_commit = commit;
    k.segments = {{0.0, commit}};
    write_checkpoint(dir, k);
  };
  auto finished_at = [&](double t_end) {
    Summary s;
    s.t_end = t_end;
    s.average_from = c.run.average_from;
    s.case_json = to_json(c);
    write_summary(dir, s);
  };
  const DirectoryRequest fresh{.dir = dir}, overwrite{.dir = dir, .overwrite = true},
      restart{.dir = dir, .restart = true},
      any_version{.dir = dir, .restart = true, .any_version = true};
  using Kind = ResumePlan::Kind;

  // Nothing there: a fresh start; nothing to restart.
  CHECK(plan_output_dir(c, fresh).kind == Kind::fresh);
  CHECK_THROWS_WITH(plan_output_dir(c, restart), Catch::Contains("no checkpoint to restart from"));

  // An interrupted run at 1e-5 s.
  checkpoint_at(1e-5, kGitCommit);
  auto before = box.snapshot();
  {
    const auto refused = refusal_of(c, fresh);
    REQUIRE(refused);
    CHECK_THAT(refused->what(), Catch::Contains("holds an interrupted run of this case "
                                                "(checkpoint.bin at t = 1e-05 s)"));
    CHECK_FALSE(refused->needs_any_version);
  }
  CHECK(plan_output_dir(c, overwrite).kind == Kind::fresh);
  const ResumePlan continued = plan_output_dir(c, restart);
  CHECK(continued.kind == Kind::continue_checkpoint);
  REQUIRE(continued.checkpoint);
  CHECK(continued.checkpoint->t == 1e-5);
  // run.t_end may move, to any time not before the checkpoint's.
  CHECK(plan_output_dir(ending_at(1.5e-5), restart).kind == Kind::continue_checkpoint);
  CHECK(plan_output_dir(ending_at(1e-5), restart).kind == Kind::continue_checkpoint);
  CHECK_THROWS_WITH(plan_output_dir(ending_at(5e-6), restart),
                    Catch::Contains("run.t_end = 5e-06 s is before t = 1e-05 s"));
  CHECK(plan_output_dir(ending_at(5e-6), fresh).kind == Kind::fresh);  // no run it continues
  // Any other key may not.
  Case other = c;
  other.drive.velocity = 2e-3;
  CHECK_THROWS_WITH(plan_output_dir(other, restart),
                    Catch::Contains("written for a different case (drive.velocity: 0.001 in "
                                    "the checkpoint, 0.002 in the case)"));
  CHECK(plan_output_dir(other, fresh).kind == Kind::fresh);
  CHECK(box.snapshot() == before);

  // The same, written by another code version: continued only when asked.
  checkpoint_at(1e-5, "0000000");
  before = box.snapshot();
  {
    const auto refused = refusal_of(c, fresh);
    REQUIRE(refused);
    CHECK(refused->needs_any_version);
    CHECK_THAT(refused->what(), Catch::Contains("code version 0000000's: --any-version"));
  }
  CHECK_THROWS_WITH(plan_output_dir(c, restart),
                    Catch::Contains("written by code version 0000000"));
  CHECK(plan_output_dir(c, any_version).kind == Kind::continue_checkpoint);
  CHECK(box.snapshot() == before);

  // A damaged checkpoint: no run to continue; a restart says why.
  test::spit(dir / kCheckpointFile, "not a checkpoint\n");
  CHECK(plan_output_dir(c, fresh).kind == Kind::fresh);
  CHECK_THROWS_WITH(plan_output_dir(c, restart), Catch::Contains("not a stickslip checkpoint"));

  // A run finished at t_end = 2e-5 s that kept its final state: continued to
  // a later t_end only.
  checkpoint_at(2e-5, kGitCommit);
  finished_at(2e-5);
  before = box.snapshot();
  CHECK(plan_output_dir(c, fresh).kind == Kind::fresh);  // results: prepare_output_dir refuses
  {
    const auto refused = refusal_of(ending_at(4e-5), fresh);
    REQUIRE(refused);
    CHECK_THAT(refused->what(),
               Catch::Contains("finished at t = 2e-05 s with its final state kept, which "
                               "run.t_end = 4e-05 s extends"));
  }
  CHECK_THROWS_WITH(plan_output_dir(c, restart),
                    Catch::Contains("has finished (summary.json exists); a later run.t_end"));
  const ResumePlan extended = plan_output_dir(ending_at(4e-5), restart);
  CHECK(extended.kind == Kind::extend_finished);
  REQUIRE(extended.checkpoint);
  CHECK(extended.checkpoint->t == 2e-5);
  // A summary.json this code did not write: finished, but not continued.
  test::spit(dir / kSummaryFile, "{}");
  CHECK_THROWS_WITH(plan_output_dir(ending_at(4e-5), restart),
                    Catch::Contains("has finished") && Catch::Contains("another code version?"));
  CHECK(plan_output_dir(ending_at(4e-5), fresh).kind == Kind::fresh);
  finished_at(2e-5);
  CHECK(box.snapshot() == before);

  // Finished without its final state: nothing to continue from.
  fs::remove(dir / kCheckpointFile);
  before = box.snapshot();
  CHECK_THROWS_WITH(plan_output_dir(ending_at(4e-5), restart),
                    Catch::Contains("without keeping its final state"));
  CHECK_THROWS_WITH(plan_output_dir(c, restart),
                    Catch::EndsWith("the run there has finished (summary.json exists)"));
  CHECK(plan_output_dir(ending_at(4e-5), fresh).kind == Kind::fresh);
  CHECK(box.snapshot() == before);
}

TEST_CASE("a refused restart names the keys that differ and changes nothing", "[restart]") {
  test::Sandbox box("stickslip_restart_refused_");
  const fs::path file = box.write("tiny.toml", kTiny);
  interrupt(read_case(file), {.out_dir = box.work / "run", .quiet = true});
  const auto before = box.snapshot();
  const auto r = box.run({"run", "tiny.toml", "--restart", "run", "--set", "drive.velocity=2e-3",
                          "--set", "run.t_end=4e-5", "--quiet"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(test::lines(r.err) == 1);
  CHECK_THAT(r.err, Catch::StartsWith("error: run/checkpoint.bin: written for a different case"));
  CHECK_THAT(r.err, Catch::Contains("drive.velocity: 0.001 in the checkpoint, 0.002 in the case"));
  CHECK_THAT(r.err, Catch::Contains("run.t_end: 2e-05 in the checkpoint, 4e-05 in the case"));
  CHECK(box.snapshot() == before);

  // A key the checkpoint's case lacks (written before it existed) meant its
  // default: named with that value.
  Checkpoint older = read_checkpoint(box.work / "run");
  older.case_json["interface"].erase("patch");
  write_checkpoint(box.work / "run", older);
  const auto patch =
      box.run({"run", "tiny.toml", "--restart", "run", "--set", "interface.patch=2", "--quiet"});
  CHECK(patch.code == 2);
  CHECK_THAT(patch.err, Catch::Contains("interface.patch: 1 in the checkpoint, 2 in the case"));
}

TEST_CASE("a restart refuses a table whose columns this build does not write, changing nothing",
          "[restart]") {
  // As steps.csv of a multirate run written by a build before its miss column.
  test::Sandbox box("stickslip_restart_columns_");
  const fs::path file = box.write("tiny.toml", std::string(kTiny) + "[output]\nsteps = true\n");
  interrupt(read_case(file), {.out_dir = box.work / "run", .quiet = true});
  const fs::path steps = box.work / "run" / "steps.csv";
  std::string text;
  {
    std::ifstream in(steps);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto first_newline = text.find('\n');
  REQUIRE(text.substr(0, first_newline) == "t,h,error,h_lambda");
  std::ofstream(steps) << "t,h,error" << text.substr(first_newline);
  const auto before = box.snapshot();
  const auto r = box.run({"run", "tiny.toml", "--restart", "run", "--quiet"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Catch::Contains("run/steps.csv: its columns are t,h,error, where this build "
                                    "writes t,h,error,h_lambda"));
  CHECK(box.snapshot() == before);
}

TEST_CASE("a fresh start in a directory holding an interrupted run points to --restart",
          "[restart][cli]") {
  test::Sandbox box("stickslip_resumable_");
  const fs::path file = box.write("my case.toml", kTiny);
  // Stopped with a --set the restart must repeat.
  interrupt(read_case(file, {"run.average_from=1.2e-5"}),
            {.out_dir = box.work / "run dir", .quiet = true});
  const auto before = box.snapshot();
  const auto r = box.run(
      {"run", "my case.toml", "--out", "run dir", "--set", "run.average_from=1.2e-5", "--quiet"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Catch::StartsWith("error: run dir: holds an interrupted run of this case"));
  CHECK_THAT(r.err, Catch::Contains("--restart"));
  CHECK(r.out.empty());
  CHECK(box.snapshot() == before);
  const std::string line = continue_line(r.err);
  REQUIRE_FALSE(line.empty());
  // As printed, from another directory.
  fs::create_directories(box.root / "elsewhere");
  REQUIRE(shell_in(box.root / "elsewhere", line, box.root / "continued.txt") == 0);
  const auto summary = read_summary(box.work / "run dir");
  REQUIRE(summary);
  CHECK(summary->average_from == 1.2e-5);
  CHECK(times(box.work / "run dir", "friction").size() == 21);

  // A checkpoint of another case is no run this case continues: --overwrite, as ever.
  interrupt(read_case(file), {.out_dir = box.work / "other", .quiet = true});
  const auto other =
      box.run({"run", "my case.toml", "--out", "other", "--set", "drive.velocity=2e-3", "--quiet"});
  CHECK(other.code == 2);
  CHECK_THAT(other.err, Catch::Contains("--overwrite") && !Catch::Contains("--restart"));
}

TEST_CASE("a finished run that kept its final state continues to a later t_end only",
          "[restart][cli]") {
  const std::string format = GENERATE("csv", "hdf5");
  INFO("[output] format = " << format);
  test::Sandbox box("stickslip_extend_");
  // t_end = 2e-5; the first run ends at 1.55e-5, off the 1e-6 output grid.
  box.write("tiny.toml",
            std::string(kTiny) + "[output]\nfinal_state = true\nformat = \"" + format + "\"\n");
  auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"run", "tiny.toml", "--quiet"});
    return box.run(args);
  };
  REQUIRE(run({"--out", "straight"}).code == 0);
  REQUIRE(run({"--out", "longer", "--set", "run.t_end=1.55e-5"}).code == 0);
  CHECK(fs::exists(box.work / "longer" / kCheckpointFile));  // the final state, kept
  CHECK(read_checkpoint(box.work / "longer").t == 1.55e-5);

  // Refused, changing nothing: a start afresh (it points to --restart), an
  // earlier t_end than the run reached, the same t_end (nothing to do).
  const auto before = box.snapshot();
  const auto afresh = run({"--out", "longer"});
  CHECK(afresh.code == 2);
  CHECK_THAT(afresh.err, Catch::Contains("finished at t = 1.55e-05 s") &&
                             Catch::Contains("--restart") && Catch::Contains("continue with: "));
  const auto earlier = run({"--restart", "longer", "--set", "run.t_end=1.2e-5"});
  CHECK(earlier.code == 2);
  CHECK(test::lines(earlier.err) == 1);
  CHECK_THAT(earlier.err, Catch::Contains("longer/checkpoint.bin: run.t_end = 1.2e-05 s is "
                                          "before t = 1.55e-05 s"));
  const auto same = run({"--restart", "longer", "--set", "run.t_end=1.55e-5"});
  CHECK(same.code == 2);
  CHECK_THAT(same.err, Catch::Contains("has finished") && Catch::Contains("run.t_end"));
  CHECK(box.snapshot() == before);

  // A stop between the final checkpoint and summary.json (written in that
  // order) leaves a run that a restart with the same t_end finishes: nothing
  // left to integrate, no row written twice.
  fs::copy(box.work / "longer", box.work / "cut", fs::copy_options::recursive);
  fs::remove(box.work / "cut" / kSummaryFile);
  REQUIRE(run({"--restart", "cut", "--set", "run.t_end=1.55e-5"}).code == 0);
  CHECK(times(box.work / "cut", "friction") == times(box.work / "longer", "friction"));
  const auto cut = read_summary(box.work / "cut");
  REQUIRE(cut);
  CHECK(cut->mu == read_summary(box.work / "longer")->mu);

  // The case file's t_end, 2e-5, the only change: continued.
  const auto extended = run({"--restart", "longer"});
  INFO(extended.err);
  REQUIRE(extended.code == 0);
  const auto summary = read_summary(box.work / "longer");
  REQUIRE(summary);
  CHECK(summary->t_end == 2e-5);
  REQUIRE(summary->segments.size() == 2);
  CHECK(summary->segments[1].from == 1.55e-5);
  // Every output time of the straight run, and the first run's last row at
  // its t_end, off the grid, kept.
  auto expected = times(box.work / "straight", "friction");
  expected.insert(expected.begin() + 16, 1.55e-5);
  const auto rows = times(box.work / "longer", "friction");
  REQUIRE(rows.size() == expected.size());
  for (std::size_t k = 0; k < rows.size(); ++k) CHECK(rows[k] == Approx(expected[k]));
  CHECK(read_run_columns(box.work / "longer", "final_state").at(0).second.front() == 2e-5);
  const auto straight = read_summary(box.work / "straight");
  REQUIRE(straight);
  CHECK(summary->mu == Approx(straight->mu).epsilon(1e-5));

  // Without its final state a finished run cannot continue: said so, with the key.
  REQUIRE(run({"--out", "plain", "--set", "run.t_end=1.55e-5", "--set", "output.final_state=false"})
              .code == 0);
  CHECK_FALSE(fs::exists(box.work / "plain" / kCheckpointFile));
  const auto plain_before = box.snapshot();
  const auto plain = run({"--restart", "plain", "--set", "output.final_state=false"});
  CHECK(plain.code == 2);
  CHECK(test::lines(plain.err) == 1);
  CHECK_THAT(plain.err, Catch::Contains("without keeping its final state") &&
                            Catch::Contains("[output] final_state = true"));
  CHECK(box.snapshot() == plain_before);
}

TEST_CASE("a run continued to a later t_end agrees with one run there straight",
          "[slow][restart]") {
  // kCase to t_end = 1 ms, its final state kept, then continued to 1.5 ms (a
  // --set, or a case file whose only change is t_end), against a run to
  // 1.5 ms: the standard of an interrupted run's restart above. dirk at
  // rtol 1e-7 with tolerances that follow it, as fast as imex is slow.
  const test::TempDir tmp("stickslip_test_extend");
  const fs::path& box = tmp.path;
  const std::string common = std::string(kCase) + "final_state = true\n";
  auto with_t_end = [&](const std::string& t_end) {
    std::string text = common;
    text.replace(text.find("t_end = 1.5e-3"), 14, "t_end = " + t_end);
    return text;
  };
  std::ofstream(box / "short.toml") << with_t_end("1e-3");
  std::ofstream(box / "long.toml") << with_t_end("1.5e-3");
  const std::string exe = STICKSLIP_EXE;
  const std::string dirk =
      " --set 'solver.method=\"dirk\"' --set solver.atol_velocity=4.75e-12"
      " --set solver.atol_displacement=1.95e-14 --quiet >/dev/null";
  auto run = [&](const std::string& args) {
    return shell("cd " + box.string() + " && " + exe + " run " + args + dirk);
  };
  REQUIRE(run("long.toml --out straight") == 0);
  REQUIRE(run("short.toml --out by_set") == 0);
  REQUIRE(run("short.toml --restart by_set --set run.t_end=1.5e-3") == 0);
  REQUIRE(run("short.toml --out by_file") == 0);
  REQUIRE(run("long.toml --restart by_file") == 0);

  const auto straight_t = times(box / "straight", "friction");
  REQUIRE(straight_t.size() == 1501);
  for (const char* extended : {"by_set", "by_file"}) {
    INFO(extended);
    const auto summary = read_summary(box / extended);
    REQUIRE(summary);
    CHECK(summary->t_end == 1.5e-3);
    REQUIRE(summary->segments.size() == 2);
    CHECK(summary->segments[1].from == 1e-3);
    CHECK(times(box / extended, "friction") == straight_t);  // no gap, no duplicate
    CHECK(times(box / extended, "traces") == straight_t);
    const CompareResult r = compare_runs(box / "straight", box / extended, 2e-2);
    INFO(to_json(r).dump(1));
    CHECK(r.pass());
    CHECK(r.mu_rel_diff < 1e-5);
    for (const auto& e : r.events) {
      CHECK(e.unmatched_a == 0);
      CHECK(e.unmatched_b == 0);
      CHECK(e.max_dt < 1e-7);  // 1/30 of a slip's duration
    }
    CHECK(read_run_columns(box / extended, "final_state").at(0).second.front() == 1.5e-3);
  }
}

namespace {

// `args` run by the binary in `cwd`, in the background, its output discarded:
// its pid, to stop, kill and wait for as a test needs.
pid_t start_run(const fs::path& cwd, std::vector<std::string> args) {
  std::string exe = STICKSLIP_EXE;
  std::vector<char*> argv{exe.data()};
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {  // only async-signal-safe calls until exec
    const int null = open("/dev/null", O_WRONLY);
    if (chdir(cwd.c_str()) != 0 || null < 0) _exit(127);
    dup2(null, STDOUT_FILENO);
    dup2(null, STDERR_FILENO);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

std::string exact(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", x);
  return text;
}

}  // namespace

TEST_CASE(
    "a run into a live run's directory is refused and touches nothing, and a killed run's "
    "lock does not block",
    "[restart][cli]") {
  test::Sandbox box("stickslip_live_run_");
  box.write("two.toml", kCase);
  // Long enough to be caught alive (it is stopped, then killed long before
  // its end), checkpointing often.
  const fs::path live = box.work / "live";
  const std::vector<std::string> sets = {"--set", "run.average_from=1e-6"};
  std::vector<std::string> first = {"run",
                                    "two.toml",
                                    "--out",
                                    "live",
                                    "--quiet",
                                    "--set",
                                    "run.t_end=1e-2",
                                    "--set",
                                    "run.checkpoint_every=2e-5"};
  first.insert(first.end(), sets.begin(), sets.end());
  const pid_t pid = start_run(box.work, first);
  REQUIRE(pid > 0);
  for (int k = 0; k < 3000 && !fs::exists(live / kCheckpointFile); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  REQUIRE(fs::exists(live / kCheckpointFile));
  // Stopped, the run writes nothing more but is alive and holds its directory.
  REQUIRE(kill(pid, SIGSTOP) == 0);
  int status = 0;
  REQUIRE(waitpid(pid, &status, WUNTRACED) == pid);
  REQUIRE(WIFSTOPPED(status));
  const double checkpoint_t = read_checkpoint(live).t;
  const auto before = box.snapshot();

  // A fresh start, one with --overwrite (a short run: the old code finished
  // it over the live one's files) and a restart: each refused, naming the
  // directory and the live run, and nothing there changes.
  const std::vector<std::vector<std::string>> requests = {
      {"--out", "live", "--set", "run.t_end=1e-4"},
      {"--out", "live", "--overwrite", "--set", "run.t_end=1e-4"},
      {"--restart", "live", "--set", "run.t_end=" + exact(checkpoint_t + 1e-5)}};
  for (const auto& request : requests) {
    std::vector<std::string> args{"run", "two.toml", "--quiet"};
    args.insert(args.end(), request.begin(), request.end());
    args.insert(args.end(), sets.begin(), sets.end());
    const auto r = box.run(args);
    INFO(request[0] << " " << request[1] << " " << request[2] << ": " << r.err);
    CHECK(r.code == 2);
    CHECK(test::lines(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("error: live: a live run is writing there (pid " +
                                        std::to_string(pid)));
    // Not the advice for a stopped run: a restart beside the live one.
    CHECK_THAT(r.err, !Catch::Contains("interrupted") && !Catch::Contains("continue with:"));
    CHECK(box.snapshot() == before);
  }

  // Killed (as by the OOM killer), the run leaves its lock file, which the
  // OS no longer holds: a restart continues it.
  REQUIRE(kill(pid, SIGKILL) == 0);
  REQUIRE(waitpid(pid, &status, 0) == pid);
  CHECK(fs::exists(live / "run.lock"));
  const auto continued =
      box.run({"run", "two.toml", "--quiet", "--restart", "live", "--set",
               "run.t_end=" + exact(read_checkpoint(live).t + 1e-5), sets[0], sets[1]});
  INFO(continued.err);
  CHECK(continued.code == 0);
  CHECK(read_summary(live));
  CHECK_FALSE(fs::exists(live / "run.lock"));  // a clean end leaves no lock behind
}

TEST_CASE("a run's directory is locked for its lifetime, in one process too", "[restart]") {
  // Two runs of one process (the Python module's threads) exclude each other
  // as two processes do; the lock goes when the run does, however it ends.
  test::Sandbox box("stickslip_run_lock_");
  const Case c = parse_case(kTiny, box.work / "tiny.toml");
  const fs::path dir = box.work / "run";
  interrupt(c, {.out_dir = dir, .quiet = true});
  CHECK_FALSE(fs::exists(dir / kRunLockFile));  // an interrupted run lets go of it
  const auto before = box.snapshot();
  {
    const RunLock live(dir, true);
    for (const RunOptions& second : {RunOptions{.out_dir = dir, .quiet = true},
                                     RunOptions{.out_dir = dir, .overwrite = true, .quiet = true},
                                     RunOptions{.out_dir = dir, .quiet = true, .restart = true}}) {
      INFO("overwrite " << second.overwrite << ", restart " << second.restart);
      try {
        run_case(c, second);
        FAIL("a second run was not refused");
      } catch (const LiveRunError& e) {
        CHECK(e.pid == getpid());
        CHECK_THAT(e.what(),
                   Catch::StartsWith(dir.string() + ": a live run is writing there (pid " +
                                     std::to_string(getpid()) + " on "));
      }
      // The lock file aside (the live run's own), nothing there changed.
      auto now = box.snapshot();
      CHECK(now.erase("run/" + std::string(kRunLockFile)) == 1);
      CHECK(now == before);
    }
  }
  // Let go: the run continues, and leaves no lock file as it ends.
  CHECK_FALSE(fs::exists(dir / kRunLockFile));
  CHECK(run_case(c, {.out_dir = dir, .quiet = true, .restart = true}).t_end == 2e-5);
  CHECK_FALSE(fs::exists(dir / kRunLockFile));

  // A lock file no process holds (its run killed) blocks nothing, whatever it says.
  test::spit(dir / kRunLockFile, "pid 1\nhost elsewhere\nstarted long ago\n");
  CHECK(run_case(c, {.out_dir = dir, .overwrite = true, .quiet = true}).t_end == 2e-5);
  CHECK_FALSE(fs::exists(dir / kRunLockFile));

  // A run that fails lets go too.
  Case failing = c;
  failing.solver.max_steps = 1;
  CHECK_THROWS_AS(run_case(failing, {.out_dir = box.work / "failing", .quiet = true}),
                  IntegrationError);
  CHECK_FALSE(fs::exists(box.work / "failing" / kRunLockFile));
  const RunLock again(box.work / "failing", false);  // and it is free
}

TEST_CASE("a restart refuses a corrupted checkpoint, leaving it as it was", "[restart][cli]") {
  test::Sandbox box("stickslip_corrupt_checkpoint_");
  const fs::path file = box.write("tiny.toml", kTiny);
  interrupt(read_case(file), {.out_dir = box.work / "run", .quiet = true});
  const fs::path checkpoint = box.work / "run" / kCheckpointFile;
  const std::size_t state_bytes = read_checkpoint(box.work / "run").state.size() * sizeof(double);
  std::string bytes = test::slurp(checkpoint);
  REQUIRE(state_bytes > 200);
  REQUIRE(bytes.size() > state_bytes);
  // 100 bytes in the middle of the saved state (the end of the file), each
  // with its lowest bit flipped: numbers still, but not the run's.
  const std::size_t middle = bytes.size() - state_bytes / 2;
  for (std::size_t k = middle - 50; k < middle + 50; ++k) bytes[k] ^= 0x01;
  test::spit(checkpoint, bytes);
  const auto before = box.snapshot();
  const auto r = box.run({"run", "tiny.toml", "--restart", "run", "--quiet"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(test::lines(r.err) == 1);
  CHECK_THAT(r.err, Catch::StartsWith("error: run/checkpoint.bin: checksum mismatch: the "
                                      "checkpoint is corrupted"));
  CHECK_THAT(r.err, Catch::Contains("--overwrite"));
  CHECK(box.snapshot() == before);
}

TEST_CASE("a checkpoint proves its header too, and one written before checksums still reads",
          "[restart]") {
  const test::TempDir tmp("stickslip_test_checkpoint_checksum");
  const Case c = parse_case(kTiny, tmp.path / "tiny.toml");
  Checkpoint k;
  k.t = 1e-5;
  k.output_index = 10;
  k.state = {1.0, -2.5, 3e-7};
  k.case_json = to_json(c);
  k.git_commit = "0000000";
  write_checkpoint(tmp.path, k);
  const fs::path file = tmp.path / kCheckpointFile;
  const std::string written = test::slurp(file);
  CHECK(read_checkpoint(tmp.path).state == k.state);

  // A digit of t changed in the header, which still parses: refused.
  std::string changed = written;
  const auto at = changed.find("\"t\":1e-05");
  REQUIRE(at != std::string::npos);
  changed[at + 4] = '2';
  test::spit(file, changed);
  CHECK_THROWS_WITH(read_checkpoint(tmp.path),
                    Catch::StartsWith(file.string() + ": checksum mismatch: the checkpoint is "
                                                      "corrupted"));
  CHECK(test::slurp(file) == changed);

  // The format before checksums (a magic line, the header, the state) is
  // read as it was: an older code version's, continued with --any-version.
  const nlohmann::json header = {{"t", 1e-5},
                                 {"output_index", 10},
                                 {"impulse_at_average", nullptr},
                                 {"state_size", 3},
                                 {"stats", SolverStats{}},
                                 {"case", to_json(c)},
                                 {"git_commit", "0000000"}};
  const double state[3] = {1.0, -2.5, 3e-7};
  test::spit(file, "stickslip-checkpoint 1\n" + header.dump() + "\n" +
                       std::string(reinterpret_cast<const char*>(state), sizeof state));
  const Checkpoint older = read_checkpoint(tmp.path);
  CHECK(older.t == 1e-5);
  CHECK(older.state == k.state);
  CHECK(older.tables.empty());  // how far its tables reached is unknown
}

TEST_CASE("a restart refuses a table that ends before the checkpoint, changing nothing",
          "[restart][cli]") {
  test::Sandbox box("stickslip_short_table_");
  const fs::path file = box.write("tiny.toml", kTiny);
  const fs::path dir = box.work / "run";
  // Stopped after ten output times, as SIGTERM from outside would.
  bool stop = false;
  RunOptions options{.out_dir = dir, .quiet = true};
  options.stop_signal = [&] { return stop ? SIGTERM : 0; };
  {
    CaseRun run(read_case(file), options);
    for (int k = 0; k < 10; ++k) run.output();
    stop = true;
    REQUIRE_THROWS_AS(run.output(), Interrupted);
  }
  const double checkpoint_t = read_checkpoint(dir).t;
  REQUIRE(checkpoint_t >= 1e-5);
  // friction.csv loses its rows after 8 µs (as a copy cut short would).
  const fs::path friction = dir / "friction.csv";
  std::string kept;
  {
    std::ifstream in(friction);
    std::string line;
    std::getline(in, line);
    kept = line + '\n';
    while (std::getline(in, line) && std::strtod(line.c_str(), nullptr) < 8.5e-6)
      kept += line + '\n';
  }
  test::spit(friction, kept);
  REQUIRE(first_column(friction).back() == Approx(8e-6));
  const auto before = box.snapshot();
  const auto r = box.run({"run", "tiny.toml", "--restart", "run", "--quiet"});
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(test::lines(r.err) == 1);
  char checkpoint_at[32];
  std::snprintf(checkpoint_at, sizeof checkpoint_at, "%.9g s", checkpoint_t);
  CHECK_THAT(r.err, Catch::StartsWith("error: run/friction.csv: ends at t = 8e-06 s, before the "
                                      "checkpoint's t = " +
                                      std::string(checkpoint_at)));
  CHECK_THAT(r.err, Catch::Contains("--overwrite"));
  CHECK(box.snapshot() == before);
}
