// stickslip: parse → build → integrate → write. Exit codes: 0 success,
// 1 the integration failed, 2 bad input (case file, options, output directory).
// `stickslip compare`: 0 within tolerance, 1 beyond it, 2 bad input
// (stickslip/analysis/compare.hpp).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "stickslip/analysis/compare.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/integrate/sundials.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/run/run.hpp"

namespace {

int run_command(const std::string& case_file, const std::string& out, const std::string& restart,
                const std::vector<std::string>& sets, bool overwrite, bool quiet) {
  using namespace stickslip;
  std::filesystem::path dir;  // known once the case is read
  try {
    const Case c = read_case(case_file, sets);
    RunOptions options;
    options.out_dir = restart.empty() ? output_dir_for(c, out) : std::filesystem::path(restart);
    options.overwrite = overwrite;
    options.quiet = quiet;
    options.restart = !restart.empty();
    dir = options.out_dir;
    install_stop_handlers();
    const RunResult r = run_case(c, options);
    std::printf(
        "mu = %.6f  (theta = %.4f, %zu contacts, energy residual %.2e, %ld steps, %.1f s)\n", r.mu,
        r.theta, r.contacts, r.energy_residual, r.stats.steps, r.wall_seconds);
    std::printf("outputs in %s\n", options.out_dir.string().c_str());
    return 0;
  } catch (const Interrupted& stop) {
    std::string sets_text;
    for (const auto& set : sets) sets_text += " --set '" + set + "'";
    std::fprintf(stderr,
                 "interrupted at t = %.9g s; outputs flushed and a checkpoint written in %s\n"
                 "continue with: stickslip run %s%s --restart %s\n",
                 stop.t, dir.c_str(), case_file.c_str(), sets_text.c_str(), dir.c_str());
    return 128 + stop.signal;
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "stickslip: an elastic block sliding on stick-slip contacts (3D spring-block model)"};
  app.require_subcommand(1);
  std::string case_file, out;
  std::vector<std::string> sets;
  bool overwrite = false, quiet = false;
  CLI::App* run = app.add_subcommand("run", "integrate a case file and write its outputs");
  run->add_option("case", case_file, "the case file (TOML)")->required();
  std::string restart;
  auto* out_option = run->add_option(
      "--out", out, "output directory (default: [output] dir, else out/<case name>)");
  run->add_option("--restart", restart,
                  "continue the interrupted run in this output directory from its checkpoint")
      ->excludes(out_option);
  run->add_option("--set", sets, "override a case value: section.key=value (repeatable)");
  run->add_flag("--overwrite", overwrite,
                "replace the results of an earlier run in the output directory");
  run->add_flag("--quiet", quiet, "no progress on stderr");
  std::string dir_a, dir_b, compare_out;
  double rtol = 1e-2;
  CLI::App* compare = app.add_subcommand(
      "compare", "compare two runs' outputs (A is the reference); exit 1 if beyond tolerance");
  compare->add_option("dir_a", dir_a, "output directory of run A (the reference)")->required();
  compare->add_option("dir_b", dir_b, "output directory of run B")->required();
  compare->add_option("--rtol", rtol, "relative tolerance (default 1e-2)");
  compare->add_option("--out", compare_out, "JSON report (default DIR_B/compare.json)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "error: %s (see stickslip --help)\n", e.what());
    return 2;
  }
  if (*run) return run_command(case_file, out, restart, sets, overwrite, quiet);
  if (*compare)
    return stickslip::compare_command(dir_a, dir_b, rtol, compare_out, std::cout, std::cerr);
  return 2;
}
