#include "stickslip/run/resume.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "stickslip/output/summary.hpp"
#include "stickslip/output/tables.hpp"
#include "stickslip/version.hpp"

namespace stickslip {
namespace {

std::string seconds(double t) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g s", t);
  return text;
}

// How `c` stands to the run a checkpoint holds. A restart may change only
// run.t_end: to continue a run past its first run.t_end (a finished run
// keeps its final checkpoint when [output] final_state is set), or to an
// earlier one it has not reached; never to a time before the checkpoint's.
struct Continuation {
  std::vector<CaseDifference> differences;  // every key that differs, for a message
  bool other_case = false;                  // a key besides run.t_end differs
  bool ends_before = false;                 // c's run.t_end is before the checkpoint's time
  bool continues() const { return !other_case && !ends_before; }
};

Continuation continuation(const Case& c, const Checkpoint& checkpoint) {
  Continuation k{.differences = case_differences(checkpoint.case_json, c)};
  k.other_case = std::any_of(k.differences.begin(), k.differences.end(),
                             [](const CaseDifference& d) { return d.key != "run.t_end"; });
  k.ends_before = c.run.t_end < checkpoint.t;
  return k;
}

// A fresh start in a directory holding a run of this case that a restart
// continues: say so, rather than offer --overwrite, which would throw it
// away. Anything else there (no checkpoint, a damaged one, one of another
// case) is no run this case continues.
void refuse_resumable(const Case& c, const std::filesystem::path& dir) {
  if (!std::filesystem::exists(dir / kCheckpointFile)) return;
  std::optional<Checkpoint> checkpoint;
  try {
    checkpoint = read_checkpoint(dir);
    if (!continuation(c, *checkpoint).continues()) return;
  } catch (const OutputError&) {
    return;
  }
  std::optional<Summary> finished;
  try {
    finished = read_summary(dir);
  } catch (const OutputError&) {
    return;  // not a summary this code writes: the usual refusal names it
  }
  // A finished run this case does not extend is results, as ever.
  if (finished && !(c.run.t_end > finished->t_end)) return;
  std::string what =
      dir.string() + ": holds " +
      (finished ? "a run of this case finished at t = " + seconds(finished->t_end) +
                      " with its final state kept, which run.t_end = " + seconds(c.run.t_end) +
                      " extends"
                : "an interrupted run of this case (" + std::string(kCheckpointFile) +
                      " at t = " + seconds(checkpoint->t) + ")") +
      ": continue it with --restart, or pass --overwrite to start "
      "afresh";
  const bool other_version = checkpoint->git_commit != kGitCommit;
  if (other_version)
    what += " (its checkpoint is code version " + checkpoint->git_commit +
            "'s: --any-version continues it)";
  throw ResumableRunError(what, other_version);
}

// A table a restart continues must reach the checkpoint: hold, at or before
// its time, the last row it held when the checkpoint was written. One that
// ends earlier (a copy cut short, rows removed) would be continued with a
// hole in it, its μ and events reported over rows that are not there; the
// state cannot be taken back to where the table ends, so the restart is
// refused. Rows past the checkpoint are cut back by the recorders, as ever.
void refuse_short_tables(const std::filesystem::path& dir, const Checkpoint& checkpoint) {
  for (const auto& [name, reached] : checkpoint.tables) {
    const std::optional<double> last = last_row_time(dir, name, checkpoint.t);
    // Printed to 12 digits or more, a row may read back a little below its time.
    if (last && *last >= reached - 1e-10 * std::abs(reached)) continue;
    throw OutputError(run_table_location(dir, name) + ": " +
                      (last ? "ends at t = " + seconds(*last) + ", before" : "has no row up to") +
                      " the checkpoint's t = " + seconds(checkpoint.t) +
                      ", by which it had a row at t = " + seconds(reached) +
                      ": continued, it would miss the rows in between; restore the table (from a "
                      "copy), or start the run afresh with --overwrite");
  }
}

// A restart continues from the checkpoint: same case but for run.t_end, same
// code (or any code, when asked), its tables whole up to the checkpoint.
ResumePlan plan_restart(const Case& c, const DirectoryRequest& request) {
  const auto& dir = request.dir;
  // A summary.json that does not parse (cut short outside this code, which
  // writes it atomically) is no finished run: the restart replaces it.
  std::optional<Summary> finished;
  try {
    finished = read_summary(dir);
  } catch (const OutputError& e) {  // whole JSON, but not a summary this code writes
    throw OutputError(dir.string() + ": the run there has finished (summary.json exists, " +
                      "written by another code version?): " + e.what());
  }
  const auto file = (dir / kCheckpointFile).string();
  if (finished && !std::filesystem::exists(file)) {
    if (c.run.t_end > finished->t_end)
      throw OutputError(dir.string() +
                        ": the run there finished at t = " + seconds(finished->t_end) +
                        " without keeping its final state, so it cannot be continued to "
                        "run.t_end = " +
                        seconds(c.run.t_end) +
                        ": a run keeps it when its case sets [output] final_state = true (run "
                        "it again with that, and --overwrite)");
    throw OutputError(dir.string() + ": the run there has finished (summary.json exists)");
  }
  Checkpoint checkpoint = read_checkpoint(dir);
  const Continuation k = continuation(c, checkpoint);
  if (k.other_case)
    throw OutputError(file + ": written for a different case (" +
                      describe(k.differences, "checkpoint") +
                      "); a restart may change only run.t_end: restart with the case file it "
                      "came from");
  if (finished && c.run.t_end == checkpoint.t)
    throw OutputError(dir.string() +
                      ": the run there has finished (summary.json exists); a later run.t_end "
                      "(--set run.t_end=...) continues it");
  if (k.ends_before)
    throw OutputError(file + ": run.t_end = " + seconds(c.run.t_end) +
                      " is before t = " + seconds(checkpoint.t) +
                      ", which the run there has already reached: a restart continues a run "
                      "to a later time only");
  if (checkpoint.git_commit != kGitCommit && !request.any_version)
    throw OutputError(file + ": written by code version " + checkpoint.git_commit + ", this is " +
                      kGitCommit + " (--any-version continues it anyway)");
  refuse_short_tables(dir, checkpoint);
  return {finished ? ResumePlan::Kind::extend_finished : ResumePlan::Kind::continue_checkpoint,
          std::move(checkpoint)};
}

}  // namespace

ResumePlan plan_output_dir(const Case& c, const DirectoryRequest& request) {
  if (request.restart) return plan_restart(c, request);
  if (!request.overwrite) refuse_resumable(c, request.dir);
  return {};
}

}  // namespace stickslip
