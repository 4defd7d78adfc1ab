#pragma once
// What a run does with its output directory, decided before anything is
// built: start afresh, continue the interrupted run there from its
// checkpoint, or continue the finished run there (which kept its final
// state) to a later run.t_end. Every rule of restart admission is here,
// once: a restart may change only run.t_end, to a time the run has not
// passed; it continues only a checkpoint of this code version unless asked;
// and a fresh start is refused where a restart is what the user wants.
// Whether another run is writing to the directory is asked first, by taking
// its lock (run/run_lock.hpp): every rule here assumes no other run is.

#include <filesystem>
#include <optional>
#include <string>

#include "stickslip/case/case.hpp"
#include "stickslip/output/checkpoint.hpp"
#include "stickslip/output/writers.hpp"

namespace stickslip {

// A run started afresh (no restart, no overwrite) in an output directory that
// holds a run this case continues: stopped by a signal, or finished with its
// final state kept and the case asking for a later run.t_end. A restart is
// what the user wants, not --overwrite; the command line prints the command.
class ResumableRunError : public OutputError {
 public:
  ResumableRunError(const std::string& what, bool needs_any_version)
      : OutputError(what), needs_any_version(needs_any_version) {}
  // The checkpoint is another code version's: the restart needs --any-version.
  bool needs_any_version;
};

// What a run is asked to do with its output directory: RunOptions' fields of
// the same names (run/run.hpp).
struct DirectoryRequest {
  std::filesystem::path dir;
  bool restart = false;      // continue the run in `dir`
  bool overwrite = false;    // a fresh start may replace the results in `dir`
  bool any_version = false;  // a restart may continue another code version's checkpoint
};

struct ResumePlan {
  enum class Kind {
    fresh,                // a new run
    continue_checkpoint,  // the interrupted run in the directory, from its checkpoint
    extend_finished,      // the finished run there, from its final state, to a later t_end
  };
  Kind kind = Kind::fresh;
  std::optional<Checkpoint> checkpoint;  // the run continued; none for a fresh start
};

// The plan for running `c` in request.dir. It reads the directory and
// changes nothing. Refused: with ResumableRunError, a fresh start (without
// overwrite) where the directory holds a run this case continues; with
// OutputError, a restart that cannot be (a finished run without its final
// state or with nothing left to run, no checkpoint or a damaged one, another
// case, an earlier run.t_end, another code version, a table that ends before
// the checkpoint's time or is missing). A fresh start in a
// directory holding other results is refused when the directory is prepared
// (prepare_output_dir).
ResumePlan plan_output_dir(const Case& c, const DirectoryRequest& request);

}  // namespace stickslip
