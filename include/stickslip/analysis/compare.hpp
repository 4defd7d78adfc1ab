#pragma once
// `stickslip compare DIR_A DIR_B`: how far apart two runs' outputs are, A being
// the reference. Reads each directory's summary.json and, where both runs have
// them, their traces and events tables (CSV or HDF5, output/tables.hpp);
// touches nothing but the report it is asked to write.
//
// Tolerance rule (rtol, default 1e-2). The comparison fails if
//   - |μ_B − μ_A| / |μ_A| > rtol, or
//   - for any trace column present in both runs, the relative L2 difference
//     RMS(B − A) / S > rtol, S the largest RMS(A) over the common columns (B
//     interpolated linearly onto A's times over the interval both cover; a
//     column with no common time fails), or
//   - for any contact and kind, the i-th events of A and B (in time order)
//     differ in time by more than rtol × t_end of A, or
//   - any event has no partner (one run has more events of a contact and kind).
// Non-finite differences (NaN in a file, μ_A = 0 ≠ μ_B) fail. A file present in
// only one run (traces.csv, events.csv), or trace columns in only one, is
// reported but is not a failure: the runs may simply have traced differently.
// Exit codes of the command: 0 within tolerance, 1 some difference exceeds it,
// 2 bad input (CompareError), including an unwritable report.

#include <filesystem>
#include <iosfwd>
#include <nlohmann/json_fwd.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "stickslip/core/events.hpp"
#include "stickslip/output/tables.hpp"

namespace stickslip {

// Bad input: a missing directory or summary.json, an unreadable or malformed
// file. what() is "<file>: <why>".
class CompareError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TraceDiff {
  std::string column;    // e.g. "vx_0"
  long samples = 0;      // A's samples inside the common time interval
  double l2 = 0.0;       // RMS of B − A over those samples
  double max_abs = 0.0;  // max |B − A|
  double rms_a = 0.0;    // RMS of A over those samples
  double rel_l2 = 0.0;   // l2 / the largest rms_a of the run (0 if all are identically 0)
};

struct EventDiff {
  int contact = 0;
  EventKind kind = EventKind::slip;
  long matched = 0;      // min(events of A, events of B)
  double max_dt = 0.0;   // max |t_B − t_A| over matched pairs [s] (NaN if none)
  double mean_dt = 0.0;  // mean |t_B − t_A| [s] (NaN if none)
  long unmatched_a = 0;  // A's events beyond B's count
  long unmatched_b = 0;  // B's events beyond A's count
};

struct CompareResult {
  std::filesystem::path dir_a, dir_b;
  double rtol = 0.0;
  double mu_a = 0.0, mu_b = 0.0;
  double mu_rel_diff = 0.0;      // |μ_B − μ_A| / |μ_A| (0 if both are 0)
  double t_end_a = 0.0;          // case.run.t_end of A [s]
  double event_tolerance = 0.0;  // rtol × t_end_a [s]

  bool traces_a = false, traces_b = false;  // the traces table present
  std::vector<TraceDiff> traces;            // common columns, in A's order
  std::vector<std::string> columns_only_a, columns_only_b;

  bool events_a = false, events_b = false;  // the events table present
  std::vector<EventDiff> events;            // by contact, then slip before stick

  std::vector<std::string> failures;  // one line per tolerance violated
  bool pass() const { return failures.empty(); }
};

// Compares the runs in dir_a (reference) and dir_b. Throws CompareError for
// bad input (also for rtol < 0 or not finite).
CompareResult compare_runs(const std::filesystem::path& dir_a, const std::filesystem::path& dir_b,
                           double rtol = 1e-2);

nlohmann::json to_json(const CompareResult& r);  // NaN → null

// The short human-readable report printed by the command.
void print_report(std::ostream& out, const CompareResult& r);

// The whole command, for main and for tests: compares, prints the report to
// `out`, writes the JSON to `json_file` (empty: dir_b/compare.json), and
// returns the exit code (0, 1 or 2; on 2 a one-line "error: <file>: <why>"
// goes to `err`).
int compare_command(const std::filesystem::path& dir_a, const std::filesystem::path& dir_b,
                    double rtol, const std::filesystem::path& json_file, std::ostream& out,
                    std::ostream& err);

}  // namespace stickslip
