#pragma once
// Sweeps: one base case, lists of values for case keys, every combination run
// in its own directory. A sweep file:
//
//     [sweep]
//     case = "fig7_base.toml"            # the base case, relative to this file
//     average_over = "interface.seed"    # sweep_summary.csv averages over it (default)
//     [vary]                             # every combination of these
//     interface.coverage = [0.04, 0.1, 0.2]
//     interface.seed = [1, 2, 3, 4, 5]
//     [[vary.together]]                  # keys that change in step (optional)
//     lattice.nx = [6, 12]
//     interface.patch = [1, 2]
//     [set]                              # the same for every point (optional)
//     run.t_end = 0.02
//
// A point is finished when its directory holds a complete summary.json
// written by this code version for exactly this point's case; a sweep started
// again runs only the others, and refuses (unless told to recompute them)
// points whose results came from another code version or case.

#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "stickslip/case/case.hpp"

namespace stickslip {

struct SweepAxis {
  std::string key;                  // "interface.coverage"
  std::vector<std::string> values;  // each as TOML text, as --set takes it
  std::vector<std::string> labels;  // each as shown in directory names and CSV
  int line = 0;                     // where the list is in the sweep file
  // Axes with the same group change in step (a [[vary.together]] table): the
  // points are every combination of the groups, not of the axes.
  std::size_t group = 0;
};

struct Sweep {
  std::filesystem::path source;     // the sweep file
  std::filesystem::path base_case;  // resolved against the sweep file's directory
  std::vector<SweepAxis> axes;      // in the order of the sweep file
  std::vector<std::string> fixed;   // [set] as "key=value" overrides
  std::string average_over = "interface.seed";
};

struct SweepPoint {
  std::size_t index = 0;               // in the order of the combinations (first axis slowest)
  std::vector<std::string> labels;     // one per axis
  std::vector<std::string> overrides;  // [set] then the axis values, "key=value"
  std::string name;                    // its directory, e.g. "coverage=0.1_seed=2"
  Case c;                              // validated
};

// Reads and validates a sweep file and every point it makes (CaseError, with
// file, line and key, on any problem: nothing has run or been written yet).
// `extra_sets` (from --set) apply to every point, after [set].
Sweep read_sweep(const std::filesystem::path& file,
                 const std::vector<std::string>& extra_sets = {});
std::vector<SweepPoint> sweep_points(const Sweep& sweep);

enum class PointState { absent, incomplete, finished, stale, failed };
const char* to_string(PointState);

// What the point's directory holds; `why` says what makes a point stale.
// With `any_version`, a point finished by another code version counts as
// finished (its row in sweep.csv names that version's git commit): for long
// studies whose code changed in ways that leave the numbers alone.
PointState point_state(const SweepPoint& point, const std::filesystem::path& dir,
                       std::string* why = nullptr, bool any_version = false);

// The sweep's tables in its output directory (write_sweep_tables).
inline constexpr const char* kSweepFile = "sweep.csv";
inline constexpr const char* kSweepSummaryFile = "sweep_summary.csv";

// sweep.csv (one row per point: swept values, status, μ, θ, slip statistics,
// synchronization when two contacts are watched, solver statistics, wall time)
// and sweep_summary.csv (mean, standard deviation and count of μ over
// `average_over` for every other combination), from the points' summaries.
// Both written atomically. Returns the number of finished points.
std::size_t write_sweep_tables(const Sweep& sweep, const std::vector<SweepPoint>& points,
                               const std::filesystem::path& out_dir, bool any_version = false);

// `--shard i/n` for scheduler job arrays: this process runs the points whose
// index ≡ i (mod n). Throws CaseError unless 0 ≤ i < n, both integers.
struct Shard {
  int index = 0, count = 1;
};
Shard parse_shard(const std::string& text);

struct SweepOptions {
  std::filesystem::path out_dir;
  int jobs = 1;                      // points run at once on this process
  bool overwrite = false;            // recompute points from another code version or case
  bool any_version = false;          // keep points finished by another code version (point_state),
                                     // and continue their checkpoints (run --any-version)
  int rank = 0, ranks = 1;           // this process's share: points with index % ranks == rank
                                     // (an MPI rank, or a shard of a job array)
  std::filesystem::path executable;  // the stickslip binary that runs each point
  // Each point's `run --threads`: 1 where points run side by side (--jobs
  // above 1, MPI ranks), so cores are never oversubscribed; 0 leaves the
  // case's [solver] threads (by default every core the process may use).
  int threads_per_point = 0;
};

struct SweepOutcome {
  std::size_t points = 0, skipped = 0, ran = 0, failed = 0;
  int interrupted_by = 0;  // the signal that stopped the sweep, 0 if none
};

// Runs this process's share of the points not yet finished, `jobs` at a time,
// each as `stickslip run` in a child process (output in <point>/run.log), a
// point interrupted earlier continuing from its checkpoint. Prints one line
// per point to `log`. Throws OutputError (before running anything) if a point
// is stale and overwrite is off.
SweepOutcome run_sweep(const Sweep& sweep, const std::vector<SweepPoint>& points,
                       const SweepOptions& options, std::ostream& log);

}  // namespace stickslip
