#pragma once
// summary.json, typed: what a run reports (written by the run and its
// recorders) and what sweeps and compare read back. One struct, one JSON
// mapping both ways, so a field is named in one place. NaN and "not
// defined" are null in the JSON and NaN / empty here.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "stickslip/core/cycles.hpp"
#include "stickslip/core/events.hpp"
#include "stickslip/integrate/solver_stats.hpp"

namespace stickslip {

inline constexpr const char* kSummaryFile = "summary.json";

// μ over whole block cycles: between the first and the last block slip's
// onset in the window (core/cycles.hpp).
struct WholeCycleMu {
  double mu = 0.0;
  double from = 0.0, to = 0.0;  // [s]
  long block_slips = 0;         // onsets in the window, ≥ 2
  double period = 0.0;          // mean time between them [s]
  double error = 0.0;           // standard error of mu from the cycles' means; NaN below two cycles
};

// Per-contact statistics of the watched contacts over the averaging window.
struct EventSummary {
  long count = 0;  // events of the whole run
  double window_from = 0.0, window_to = 0.0;
  std::vector<ContactEventStats> per_contact;
};

// One attempt of a run: from where it started (0, or a checkpoint's time) and
// the code version that ran it. A restart with --any-version may continue a
// run with another version; summary.json lists every attempt's.
struct RunSegment {
  double from = 0.0;  // [s]
  std::string git_commit;
};

// Something a user of the result must know (summary.json's "warnings"):
// `about` names what it questions ("mu", "rtol").
struct SummaryWarning {
  std::string about, text;
};

struct Summary {
  double mu = 0.0;  // over [average_from, t_end], from the friction impulse
  // Its standard error (NaN where it cannot be had: fewer than two pieces
  // between block slips, or too few samples) and how it was estimated
  // ("block cycles", "autocorrelation"; core/cycles.hpp). Not the spread of
  // seeds: a sweep gives that.
  double mu_error = 0.0;
  std::string mu_error_from;
  bool average_auto = false;  // average_from was found from F_f (run.average_from = "auto")
  long window_samples = 0;    // F_f's output samples in the window
  std::optional<WholeCycleMu> mu_whole_cycles;  // with two block slips or more in the window
  // The block slips of the whole run, found from F_f (core/cycles.hpp):
  // where cycles are counted, for plots/block_slips.py and anyone else.
  std::vector<BlockSlip> block_slips;
  std::optional<double> F_f_spread;  // sd/mean of F_f's samples in the window
  // What F_f does in the window (core/cycles.hpp); whether μ is a
  // friction coefficient, and what would fix it if not. Empty only for runs
  // that record no friction table.
  std::optional<WindowRegime> regime;
  double theta = 0.0;
  double F_N = 0.0;  // [N]
  long contacts = 0;
  double t_end = 0.0, average_from = 0.0;  // [s]
  double wall_seconds = 0.0;
  double energy_residual = 0.0, energy_audit_bound = 0.0;
  // The audit's absolute allowance, relative to the drive's work as the bound
  // is: a residual passes when |R| ≤ energy_audit_bound + this. One absolute
  // energy tolerance over the work done (0 for a fixed step, which is held
  // to the bound alone); it matters only where little work was done.
  double energy_audit_allowance = 0.0;
  double steady_sliding_mu = 0.0;
  nlohmann::json solver;  // the integrator's description: method, tolerances, tables
  SolverStats solver_stats;
  std::string git_commit, sundials_version;  // "provenance"
  std::vector<RunSegment> segments;          // "provenance": every attempt, in order
  nlohmann::json case_json;                  // "case": the case as resolved
  std::optional<EventSummary> events;
  std::optional<Synchronization> synchronization;
  std::vector<SummaryWarning> warnings;  // mu_warning's and tolerance_warning's, if any
};

nlohmann::json to_json(const Summary& s);
// μ as a terminal line shows it: "4.3645 ± 0.058 over [0.01, 0.04] s", the
// error omitted where there is none, "(auto)" after a window found from F_f.
std::string mu_text(const Summary& s);
// What would make the window's μ a friction coefficient ("a finer
// output.interval: ...", "a later run.average_from: ...", "this drive cannot
// slide: ..."); empty if it is one, or its window was not judged.
std::string regime_fix(const Summary& s);
// The warning for a μ that is not a friction coefficient (a window on the
// loading ramp, or less than a cycle), naming what to change; empty if μ is
// one, or its window was not judged.
std::string mu_warning(const Summary& s);
// The warning for a tolerance too loose to trust slip counts and times
// (rtol > kLooseRtol); empty otherwise.
inline constexpr double kLooseRtol = 1e-5;
std::string tolerance_warning(double rtol);
// Both, as the summary lists them.
std::vector<SummaryWarning> summary_warnings(const Summary& s, double rtol);
// Throws std::invalid_argument naming the first field that is missing or of
// the wrong type. Fields a summary of an older version lacks
// (mu_whole_cycles, F_f_spread) are left empty.
Summary summary_from_json(const nlohmann::json& j);

// summary.json in `dir`, written atomically.
void write_summary(const std::filesystem::path& dir, const Summary& s);
// The summary in `dir`; std::nullopt when there is none or it is cut short
// (a run still going, or killed while writing it). OutputError naming the
// file and field when it is complete JSON but not a summary.
std::optional<Summary> read_summary(const std::filesystem::path& dir);

}  // namespace stickslip
