#pragma once
// Where a run's tables go: one CSV file per table (friction.csv, ...), or one
// HDF5 file, run.h5, with a group per table and a dataset per column
// ([output] format). Recorders (output/recorder.hpp) describe their table once
// (TableSpec) and append rows; the store formats them. Reading a run's tables
// back (a restart, the end of a run, `stickslip compare`) works on either
// format: read_run_table / read_run_events look at what the directory holds.

#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "stickslip/case/case.hpp"
#include "stickslip/core/events.hpp"
#include "stickslip/output/table_store.hpp"

namespace stickslip {

// The tables of a run (each written by its recorder, output/recorders.cpp),
// by the name of their CSV file and HDF5 group: a name that code outside its
// recorder reads (a sweep, the events reader) is spelled here once.
namespace run_table {
inline constexpr const char* kContacts = "contacts";
inline constexpr const char* kFriction = "friction";
inline constexpr const char* kTraces = "traces";
inline constexpr const char* kEvents = "events";
inline constexpr const char* kSlips = "slips";
inline constexpr const char* kSteps = "steps";
inline constexpr const char* kAttempts = "attempts";
inline constexpr const char* kSignals = "signals";
inline constexpr const char* kFinalState = "final_state";
}  // namespace run_table

// The HDF5 file of a run in `format = "hdf5"`.
inline constexpr const char* kHdf5File = "run.h5";

// The store of a run's output directory; `resume`: an existing run continues
// (its files are opened, not replaced). OutputError if it cannot be opened.
std::unique_ptr<TableStore> make_table_store(OutputFormat format, const std::filesystem::path& dir,
                                             bool resume);

// A table read back: time and the other columns, by their CSV names.
struct TraceTable {
  std::vector<std::string> columns;         // without "t"
  std::vector<double> t;                    // strictly increasing
  std::vector<std::vector<double>> values;  // values[column][row]
  // Column `name`'s values; OutputError if the table has none of that name.
  const std::vector<double>& column(std::string_view name) const;
};

// Whether the run in `dir` wrote table `name`, in either format.
bool has_run_table(const std::filesystem::path& dir, const std::string& name);
// Table `name` of the run in `dir` as written so far, in either format: the
// same columns and names as its CSV file (a 2-D HDF5 dataset `vx` with member
// contact ids 0, 3 reads as columns vx_0, vx_3; HDF5 lists a 2-D dataset's
// columns together). Not for a table with a label column (events: below).
// OutputError (output/writers.hpp) if it is missing or malformed: a run that
// cannot read back its own table cannot continue (exit code 2).
TraceTable read_run_table(const std::filesystem::path& dir, const std::string& name);
// Every column of table `name` of the run in `dir`, in either format, by its
// CSV name and in its order: for a table without a time column (contacts).
// Not for a table with a label column. OutputError as read_run_table.
using NamedColumns = std::vector<std::pair<std::string, std::vector<double>>>;
NamedColumns read_run_columns(const std::filesystem::path& dir, const std::string& name);
// The time (first column) of the last row of table `name` of the run in `dir`
// at or before `t`, in either format, without reading its other columns; a
// CSV row cut off mid-write (no newline) does not count. None if it has no
// such row. OutputError if the table is missing or unreadable.
std::optional<double> last_row_time(const std::filesystem::path& dir, const std::string& name,
                                    double t);
// Where table `name` of the run in `dir` is, for a message: <dir>/<name>.csv,
// or <dir>/run.h5: /<name>.
std::string run_table_location(const std::filesystem::path& dir, const std::string& name);
// The events table of the run in `dir`, in either format.
std::vector<Event> read_run_events(const std::filesystem::path& dir);

// Readers of one CSV table (src/output/csv_tables.cpp); OutputError naming the
// file, with the line number for a malformed row.
TraceTable read_traces_csv(const std::filesystem::path& file);
NamedColumns read_columns_csv(const std::filesystem::path& file);
std::vector<Event> read_events_csv(const std::filesystem::path& file);

}  // namespace stickslip
