// stickslip: parse → build → integrate → write. Exit codes: 0 success,
// 1 the integration failed, 2 bad input (case file, options, output directory).
// `stickslip compare`: 0 within tolerance, 1 beyond it, 2 bad input
// (stickslip/analysis/compare.hpp). `stickslip sweep`: 0 every point
// finished, 1 some failed, 2 bad input, 130/143 interrupted.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "stickslip/analysis/compare.hpp"
#include "stickslip/case/keys.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/case/toml_text.hpp"
#include "stickslip/integrate/errors.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/run/resume.hpp"
#include "stickslip/run/run.hpp"
#include "stickslip/sweep/sweep.hpp"
#include "stickslip/version.hpp"

#ifdef STICKSLIP_WITH_MPI
#include <mpi.h>
#endif

namespace {

// The exit codes every command shares: 2 for bad input (case or sweep file,
// options, output directory), 1 for anything that went wrong after.
template <class Body>
int with_exit_codes(Body&& body) {
  using namespace stickslip;
  try {
    return body();
  } catch (const UnknownKeyError& e) {
    std::fprintf(stderr, "error: %s; every key: stickslip keys\n", e.what());
    return 2;
  } catch (const CaseError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const OutputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const IntegrationError& e) {
    std::fprintf(stderr, "error: integration failed: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}

// `stickslip run` as it was given, for the command that continues it.
struct RunArguments {
  // The program as started: made absolute when it was a path, so that the
  // command runs from any directory; a bare name (found on PATH) as given.
  std::string program;
  std::string case_file;            // as given
  std::filesystem::path case_path;  // absolute, resolved at startup
  std::string out, restart;
  std::vector<std::string> sets;  // the --set values as given
  int threads = -1;               // --threads, -1 if not given
  bool overwrite = false, quiet = false, any_version = false;
};

// One word for /bin/sh: as it is if it has nothing the shell would
// interpret, else in single quotes (a quote inside as '\'').
std::string shell_word(const std::string& word) {
  const bool plain = !word.empty() && word.find_first_not_of(
                                          "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                          "0123456789@%+=:,./_-") == std::string::npos;
  if (plain) return word;
  std::string quoted = "'";
  for (char ch : word) quoted += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return quoted + "'";
}

// The command that continues the run in `dir`, ready to paste into a shell
// in any directory: the same program, case and flags, with --restart in
// place of --out, and without --overwrite (which would throw the run away).
std::string continue_command(const RunArguments& a, const std::filesystem::path& dir,
                             bool any_version) {
  std::vector<std::string> words = {a.program, "run", a.case_path.string()};
  for (const auto& set : a.sets) words.insert(words.end(), {"--set", set});
  if (a.threads >= 0) words.insert(words.end(), {"--threads", std::to_string(a.threads)});
  if (a.quiet) words.emplace_back("--quiet");
  words.insert(words.end(),
               {"--restart", std::filesystem::absolute(dir).lexically_normal().string()});
  if (any_version) words.emplace_back("--any-version");
  std::string command;
  for (const auto& w : words) command += (command.empty() ? "" : " ") + shell_word(w);
  return command;
}

int run_command(const RunArguments& a) {
  using namespace stickslip;
  // From the start: a stop requested while the case is read still leaves a
  // checkpoint, at the run's first output time.
  install_stop_handlers();
  std::filesystem::path dir;  // known once the case is read
  try {
    return with_exit_codes([&] {
      std::vector<std::string> sets = a.sets;
      if (a.threads >= 0) sets.push_back("solver.threads=" + std::to_string(a.threads));
      const Case c = read_case(a.case_file, sets);
      RunOptions options;
      options.out_dir =
          a.restart.empty() ? output_dir_for(c, a.out) : std::filesystem::path(a.restart);
      options.overwrite = a.overwrite;
      options.quiet = a.quiet;
      options.restart = !a.restart.empty();
      options.any_version = a.any_version;
      dir = options.out_dir;
      try {
        const Summary r = run_case(c, options);
        std::printf(
            "mu = %s  (theta = %.4f, %ld contacts, energy residual %.2e, %ld steps, %.1f s)\n",
            mu_text(r).c_str(), r.theta, r.contacts, r.energy_residual, r.solver_stats.steps,
            r.wall_seconds);
        std::printf("outputs in %s\n", options.out_dir.string().c_str());
        std::fflush(stdout);  // the warnings after the μ they are about, also through pipes
        for (const auto& w : r.warnings) std::fprintf(stderr, "warning: %s\n", w.text.c_str());
        return 0;
      } catch (const ResumableRunError& e) {
        std::fprintf(stderr, "error: %s\ncontinue with: %s\n", e.what(),
                     continue_command(a, dir, a.any_version || e.needs_any_version).c_str());
        return 2;
      }
    });
  } catch (const Interrupted& stop) {
    std::fprintf(stderr,
                 "interrupted at t = %.9g s; outputs flushed and a checkpoint written in %s\n"
                 "continue with: %s\n",
                 stop.t, dir.c_str(), continue_command(a, dir, a.any_version).c_str());
    return 128 + stop.signal;
  }
}

// Under mpirun (built with MPI), the ranks share a sweep's points; started
// any other way the sweep is one process and MPI is never initialized.
class MpiWorld {
 public:
  MpiWorld() {
#ifdef STICKSLIP_WITH_MPI
    if (std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") ||
        std::getenv("PMIX_RANK")) {
      MPI_Init(nullptr, nullptr);
      active_ = true;
      MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
      MPI_Comm_size(MPI_COMM_WORLD, &size_);
    }
#endif
  }
  ~MpiWorld() {
#ifdef STICKSLIP_WITH_MPI
    if (active_) MPI_Finalize();
#endif
  }
  MpiWorld(const MpiWorld&) = delete;
  MpiWorld& operator=(const MpiWorld&) = delete;
  void barrier() const {
#ifdef STICKSLIP_WITH_MPI
    if (active_) MPI_Barrier(MPI_COMM_WORLD);
#endif
  }
  int rank() const {
    return rank_;
  }
  int size() const {
    return size_;
  }

 private:
  bool active_ = false;
  int rank_ = 0, size_ = 1;
};

// One task of a scheduler's job array: its share of the points, then the
// tables from every shard's points finished so far (the last shard to end
// leaves them complete; `--report` writes them again at any time). Exit 0 when
// all of this shard's points finished.
// The finished points whose μ is no friction coefficient (their window a
// loading ramp, unsettled, ...: summary.json's regime), counted and named,
// as sweep.csv's regime column and Python's sweep() say them.
void print_untrusted(const std::vector<stickslip::SweepPoint>& points,
                     const std::filesystem::path& out_dir) {
  std::vector<std::string> names;
  for (const auto& p : points) {
    std::optional<stickslip::Summary> s;
    try {
      s = stickslip::read_summary(out_dir / p.name);
    } catch (const stickslip::OutputError&) {
      continue;  // not a finished point: sweep.csv says so
    }
    if (s && s->regime && !s->regime->mu_trusted())
      names.push_back(p.name + " (" + stickslip::to_string(s->regime->kind) +
                      "): the fix: " + stickslip::regime_fix(*s));
  }
  if (names.empty()) return;
  std::printf(
      "%zu of them have a mu that is not a friction coefficient (sweep.csv's regime "
      "column):\n",
      names.size());
  for (const auto& name : names) std::printf("  %s\n", name.c_str());
}

int sweep_shard(const stickslip::Sweep& sweep, const std::vector<stickslip::SweepPoint>& points,
                stickslip::SweepOptions options, stickslip::Shard shard, int jobs) {
  using namespace stickslip;
  if (std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK"))
    throw CaseError(
        "--shard splits the points between separate jobs; under mpirun the ranks "
        "already share them: use one or the other");
  options.rank = shard.index;
  options.ranks = shard.count;
  options.jobs = jobs > 0 ? jobs : 1;
  options.threads_per_point = options.jobs > 1 ? 1 : 0;
  std::size_t mine = 0;
  for (const auto& p : points) mine += p.index % shard.count == std::size_t(shard.index);
  std::printf("sweep %s, shard %d/%d: %zu of its %zu points, %d job%s, outputs in %s\n",
              sweep.source.c_str(), shard.index, shard.count, mine, points.size(), options.jobs,
              options.jobs == 1 ? "" : "s", options.out_dir.c_str());
  std::fflush(stdout);
  const SweepOutcome outcome = run_sweep(sweep, points, options, std::cout);
  const std::size_t finished =
      write_sweep_tables(sweep, points, options.out_dir, options.any_version);
  if (outcome.interrupted_by) {
    std::fprintf(stderr, "shard interrupted: run the same command again to continue\n");
    return 128 + outcome.interrupted_by;
  }
  std::printf(
      "shard %d/%d: %zu of its points ran, %zu failed; %zu of %zu points of the sweep "
      "finished; tables: %s, %s\n",
      shard.index, shard.count, outcome.ran, outcome.failed, finished, points.size(),
      (options.out_dir / kSweepFile).c_str(), (options.out_dir / kSweepSummaryFile).c_str());
  return outcome.failed > 0 ? 1 : 0;
}

int sweep_command(const std::string& sweep_file, const std::string& out, int jobs,
                  const std::vector<std::string>& sets, bool overwrite, bool any_version,
                  bool report_only, const std::string& shard_text) {
  using namespace stickslip;
  return with_exit_codes([&] {
    const bool sharded = !shard_text.empty();
    const Shard shard = sharded ? parse_shard(shard_text) : Shard{};
    const Sweep sweep = read_sweep(sweep_file, sets);
    const auto points = sweep_points(sweep);
    SweepOptions options;
    options.out_dir = out.empty() ? std::filesystem::path("out") / sweep.source.stem()
                                  : std::filesystem::path(out);
    options.overwrite = overwrite;
    options.any_version = any_version;
    options.executable = std::filesystem::read_symlink("/proc/self/exe");
    std::error_code ec;
    std::filesystem::create_directories(options.out_dir, ec);
    if (ec)
      throw OutputError(options.out_dir.string() +
                        ": cannot create output directory: " + ec.message());
    if (access(options.out_dir.c_str(), W_OK) != 0)
      throw OutputError(options.out_dir.string() + ": output directory is not writable");

    if (report_only) {
      const std::size_t finished =
          write_sweep_tables(sweep, points, options.out_dir, options.any_version);
      std::printf("%zu of %zu points finished; tables: %s, %s\n", finished, points.size(),
                  (options.out_dir / kSweepFile).c_str(),
                  (options.out_dir / kSweepSummaryFile).c_str());
      print_untrusted(points, options.out_dir);
      return finished == points.size() ? 0 : 1;
    }
    if (sharded) return sweep_shard(sweep, points, options, shard, jobs);
    MpiWorld world;
    options.rank = world.rank();
    options.ranks = world.size();
    options.jobs = jobs > 0 ? jobs
                   : world.size() > 1
                       ? 1
                       : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    options.threads_per_point = options.jobs > 1 || world.size() > 1 ? 1 : 0;
    if (world.rank() == 0)
      std::printf(
          "sweep %s: %zu points (%zu axes), %d job%s%s, outputs in %s\n", sweep_file.c_str(),
          points.size(), sweep.axes.size(), options.jobs, options.jobs == 1 ? "" : "s",
          world.size() > 1 ? (" on each of " + std::to_string(world.size()) + " MPI ranks").c_str()
                           : "",
          options.out_dir.c_str());
    std::fflush(stdout);
    const SweepOutcome outcome = run_sweep(sweep, points, options, std::cout);
    world.barrier();
    if (outcome.interrupted_by) {
      std::fprintf(stderr, "sweep interrupted: run the same command again to continue\n");
      if (world.rank() == 0)
        write_sweep_tables(sweep, points, options.out_dir, options.any_version);
      return 128 + outcome.interrupted_by;
    }
    if (world.rank() != 0) return outcome.failed > 0 ? 1 : 0;
    const std::size_t finished =
        write_sweep_tables(sweep, points, options.out_dir, options.any_version);
    std::printf("%zu of %zu points finished (%zu already were); tables: %s, %s\n", finished,
                points.size(), outcome.skipped, (options.out_dir / kSweepFile).c_str(),
                (options.out_dir / kSweepSummaryFile).c_str());
    print_untrusted(points, options.out_dir);
    return finished == points.size() ? 0 : 1;
  });
}

// `stickslip keys [KEY] [--markdown]`: the reference of every case key, of
// one section, or of one key; an unknown one is bad input (exit 2).
int keys_command(const std::string& key, bool markdown) {
  using namespace stickslip;
  if (markdown) {
    std::fputs(keys_markdown().c_str(), stdout);
    return 0;
  }
  if (key.empty()) {
    std::fputs(keys_text().c_str(), stdout);
    return 0;
  }
  if (key.find('.') == std::string::npos) {  // a section
    const std::string text = keys_text(key);
    if (!text.empty()) {
      std::fputs(text.c_str(), stdout);
      return 0;
    }
  }
  if (const std::string problem = case_key_problem(key); !problem.empty()) {
    std::fprintf(stderr, "error: %s\n", problem.c_str());
    return 2;
  }
  for (const CaseKey& k : case_keys())
    if (k.section + "." + k.key == key) std::fputs(key_reference(k).c_str(), stdout);
  return 0;
}

// A command line CLI11 refused, said for this program: the subcommand's
// help named, an unknown option or command with the nearest valid one.
void print_command_line_error(const CLI::App& app, const CLI::ParseError& e, int argc,
                              char** argv) {
  namespace text = stickslip::toml_text;
  const CLI::App* used = nullptr;
  for (const CLI::App* sub : app.get_subcommands({}))
    if (sub->parsed()) used = sub;
  const std::string help =
      used ? "stickslip " + used->get_name() + " --help" : std::string("stickslip --help");
  std::vector<std::string> names;  // what the user may have meant
  std::string what;
  if (!used) {
    // No subcommand recognised: the first word that is not an option is a misspelt one.
    for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
    std::string word;
    for (int i = 1; i < argc && word.empty(); ++i)
      if (argv[i][0] != '-') word = argv[i];
    std::vector<std::string_view> valid(names.begin(), names.end());
    what = word.empty()
               ? "a command is required" + text::suggest("", valid)
               : "unknown command '" + text::printable(word) + "'" + text::suggest(word, valid);
  } else if (dynamic_cast<const CLI::ExtrasError*>(&e)) {
    for (const CLI::Option* o : used->get_options({}))
      for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
    std::vector<std::string_view> valid(names.begin(), names.end());
    // An unknown option's value is left over too: the options are what to name.
    const auto extras = used->remaining();
    const bool any_option = std::any_of(extras.begin(), extras.end(),
                                        [](const auto& x) { return x.rfind("-", 0) == 0; });
    for (const std::string& extra : extras) {
      const bool option = extra.rfind("-", 0) == 0;
      if (any_option && !option) continue;
      if (!what.empty()) what += "; ";
      what += option
                  ? "unknown option '" + text::printable(extra) + "'" + text::suggest(extra, valid)
                  : "unexpected argument '" + text::printable(extra) + "'";
    }
  }
  if (what.empty()) what = e.what();
  std::fprintf(stderr, "error: %s (see %s)\n", what.c_str(), help.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "stickslip: an elastic block sliding on stick-slip contacts (3D spring-block model)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("stickslip ") + stickslip::kVersion +
                                        " (git commit " + stickslip::kGitCommit + ")");
  // An empty path would silently mean the default (or the working directory).
  const CLI::Validator not_empty(
      [](const std::string& path) {
        return path.empty() ? std::string("an empty path; name a directory") : std::string();
      },
      "DIR");
  RunArguments r;
  CLI::App* run = app.add_subcommand("run", "integrate a case file and write its outputs");
  run->add_option("case", r.case_file, "the case file (TOML)")->required();
  auto* out_option = run->add_option("--out", r.out,
                                     "output directory (default: [output] dir, else out/<case "
                                     "name>); relative to the working directory")
                         ->check(not_empty);
  run->add_option("--restart", r.restart,
                  "continue the interrupted run in this output directory from its checkpoint, "
                  "or a finished one that kept its final state to a later run.t_end")
      ->excludes(out_option)
      ->check(not_empty);
  run->add_option("--set", r.sets, "override a case value: section.key=value (repeatable)");
  run->add_flag("--overwrite", r.overwrite,
                "replace the results of an earlier run in the output directory");
  run->add_flag("--quiet", r.quiet, "no progress on stderr");
  run->add_option("--threads", r.threads,
                  "OpenMP threads of the run, as [solver] threads (0: every core the process may "
                  "use; results do not depend on it)")
      ->check(CLI::Range(0, 4096));
  run->add_flag("--any-version", r.any_version,
                "with --restart: continue a checkpoint written by another code version "
                "(summary.json lists each attempt's); for changes that leave the numbers alone")
      ->needs(run->get_option("--restart"));
  std::string dir_a, dir_b, compare_out;
  double rtol = 1e-2;
  CLI::App* compare = app.add_subcommand(
      "compare", "compare two runs' outputs (A is the reference); exit 1 if beyond tolerance");
  compare->add_option("dir_a", dir_a, "output directory of run A (the reference)")->required();
  compare->add_option("dir_b", dir_b, "output directory of run B")->required();
  compare->add_option("--rtol", rtol, "relative tolerance (default 1e-2)");
  compare->add_option("--out", compare_out, "JSON report (default DIR_B/compare.json)")
      ->check(not_empty);
  std::string sweep_file, sweep_out;
  std::vector<std::string> sweep_sets;
  int jobs = 0;
  bool sweep_overwrite = false, sweep_any_version = false, sweep_report = false;
  std::string shard;
  CLI::App* sweep = app.add_subcommand(
      "sweep", "run every combination of a sweep file's values; skips points already finished");
  sweep->add_option("sweep_file", sweep_file, "the sweep file (TOML)")->required();
  sweep->add_option("--out", sweep_out, "output directory (default out/<sweep name>)")
      ->check(not_empty);
  sweep
      ->add_option("--jobs", jobs,
                   "points run at once (default: the number of cores; 1 per MPI rank)")
      ->check(CLI::Range(1, 4096));
  sweep->add_option("--set", sweep_sets, "override a case value for every point (repeatable)");
  sweep->add_flag("--overwrite", sweep_overwrite,
                  "recompute points computed by another code version or for another case");
  sweep->add_flag("--any-version", sweep_any_version,
                  "keep points finished by another code version (sweep.csv names each point's "
                  "commit) and continue their checkpoints: for code changes that leave the "
                  "numbers alone");
  sweep->add_flag("--report", sweep_report,
                  "only write sweep.csv and sweep_summary.csv from the points finished so far");
  sweep->add_option("--shard", shard,
                    "i/n: run only the points whose index is i modulo n, for job arrays "
                    "(default --jobs 1); then write the tables from all shards' points");
  std::string key;
  bool keys_markdown = false;
  CLI::App* keys =
      app.add_subcommand("keys", "every case-file key: default, unit, allowed values and meaning");
  keys->add_option("key", key, "one key (interface.v_m) or section (interface)");
  keys->add_flag("--markdown", keys_markdown, "every key as Markdown (docs/keys.md)")
      ->excludes(keys->get_option("key"));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    print_command_line_error(app, e, argc, argv);
    return 2;
  }
  if (*run) {
    // Before anything could change the working directory.
    const std::string program = argc > 0 ? argv[0] : "stickslip";
    r.program = program.find('/') == std::string::npos
                    ? program
                    : std::filesystem::absolute(program).lexically_normal().string();
    r.case_path = std::filesystem::absolute(r.case_file).lexically_normal();
    return run_command(r);
  }
  if (*sweep)
    return sweep_command(sweep_file, sweep_out, jobs, sweep_sets, sweep_overwrite,
                         sweep_any_version, sweep_report, shard);
  if (*keys) return keys_command(key, keys_markdown);
  if (*compare)
    return stickslip::compare_command(dir_a, dir_b, rtol, compare_out, std::cout, std::cerr);
  return 2;
}
