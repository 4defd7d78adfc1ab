#pragma once
// Checkpoints of a run, so a kill or a crash never costs more than the time
// since the last one. A checkpoint holds what cannot be re-read from the CSV
// outputs: the time and state, the friction impulse at t_avg, the output row
// reached, the solver statistics so far, and the case and code it belongs to.
// Events and traces before it are recovered from events.csv and traces.csv;
// what a recorder cannot recover from its table (a slip under way) it saves
// in the checkpoint itself (Recorder::save).
// Written atomically: a kill at any moment leaves the previous one whole.
// A checksum over its content proves it on reading: a checkpoint damaged
// since is refused (OutputError), and left as it is.
// A finished run whose case sets [output] final_state keeps its last, at
// t_end, from which a restart continues it to a later t_end.

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/integrate/solver_stats.hpp"
#include "stickslip/output/summary.hpp"

namespace stickslip {

struct Checkpoint {
  double t = 0.0;
  long output_index = 0;            // rows k·interval written, k ≤ output_index
  double impulse_at_average = 0.0;  // ∫F_f dt at average_from (NaN before it)
  std::vector<double> state;
  SolverStats stats;                 // accumulated up to t
  double wall_seconds = 0.0;         // accumulated over the run's attempts up to t
  nlohmann::json case_json;          // the resolved case (without paths)
  std::string git_commit;            // the version that wrote it
  std::vector<RunSegment> segments;  // the run's attempts up to it, the writer's last
  nlohmann::json recorders = nlohmann::json::object();  // what they saved, by recorder
  // By table, the time of its last row at or before t (TrackedTableStore::
  // last_rows): a restart refuses a table that no longer reaches it. Empty
  // in checkpoints of older code.
  std::map<std::string, double> tables;
};

inline constexpr const char* kCheckpointFile = "checkpoint.bin";

void write_checkpoint(const std::filesystem::path& dir, const Checkpoint& c);
// Throws OutputError naming the file when it is missing, not a checkpoint,
// or not what was written (its checksum does not match).
Checkpoint read_checkpoint(const std::filesystem::path& dir);

// The part of the resolved case that must match for a restart: everything but
// where the case file and outputs live.
nlohmann::json restart_identity(const nlohmann::json& case_json);

// Whether the case a run wrote (a checkpoint's or summary.json's "case") is
// `current` for a restart or a sweep: their restart identities agree, a key
// the written one lacks (it was written before the key existed) counting as
// the key's default.
bool same_case(const nlohmann::json& written, const Case& current);

// Where the restart identities of the case a run wrote and `current` differ
// (same rule for keys written before they existed), key by key in the
// schema's order.
struct CaseDifference {
  std::string key;      // "section.key", e.g. "run.t_end"
  std::string written;  // its value in the written case, "unset" if it has none
  std::string current;  // its value in `current`, "unset" if it has none
};
std::vector<CaseDifference> case_differences(const nlohmann::json& written, const Case& current);

// The differences for a message: "run.t_end: 0.002 in the checkpoint, 0.004
// in the case; ...", `written_as` naming where the written case came from.
std::string describe(const std::vector<CaseDifference>& differences, const std::string& written_as);

}  // namespace stickslip
