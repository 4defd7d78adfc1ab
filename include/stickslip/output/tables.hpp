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

// Table `table`'s CSV file in a run's directory: <table>.csv.
std::string csv_file_name(std::string_view table);

// Member `member` of a 2-D dataset (Column::dataset) as a column of its own,
// as a CSV header and read_run_table name it: <dataset>_<member> (traces: vx of
// contact 3 is vx_3). The Python module names them through this too.
std::string member_column(std::string_view dataset, int member);
// The member of `dataset` that column `name` is, if it is one of them
// (member_column's inverse: vx_3 → 3).
std::optional<int> column_member(std::string_view name, std::string_view dataset);

// A column's values are doubles in the row; integer and label columns hold
// whole numbers (a label column's number is the index of its text in `labels`).
enum class ColumnType { real, integer, label };

// Column::digits for values that must read back bit for bit (v*, a final
// state): the shortest text that does (0.00209, not 0.0020899999999999998).
inline constexpr int kExact = 0;

struct Column {
  std::string name{};  // CSV header; HDF5 dataset name (unless `dataset` is set)
  std::string unit{};  // HDF5 attribute "units" ("" for none)
  ColumnType type = ColumnType::real;
  int digits = 10;  // significant digits in CSV; kExact: the fewest that read back exactly
  std::vector<std::string> labels{};  // ColumnType::label: the text of 0, 1, ...
  // HDF5 only: this column is member `member` of the 2-D dataset `dataset`
  // [row × member] (traces: vx of every traced contact in one dataset).
  std::string dataset{};
  int member = -1;
};

struct TableSpec {
  std::string name;             // CSV: <name>.csv; HDF5: the group /<name>
  std::vector<Column> columns;  // the first is time, increasing, in a table a restart continues
  // HDF5 only: what the members of the 2-D datasets are (written as the
  // dataset `member_name`, e.g. traces/contact = the contact ids).
  std::string member_name{};
  std::vector<int> members{};
};

class Table {
 public:
  virtual ~Table() = default;
  // One row, a value per column in the spec's order.
  virtual void append(std::span<const double> row) = 0;
  // Everything appended so far reaches the file (a killed run keeps it).
  virtual void flush() = 0;
};

class TableStore {
 public:
  virtual ~TableStore() = default;
  // A new table, replacing one of that name.
  virtual std::unique_ptr<Table> create(const TableSpec& spec) = 0;
  // A table a restart continues: its rows after time `t` (first column) are
  // dropped and new rows appended. OutputError if it does not exist.
  virtual std::unique_ptr<Table> resume(const TableSpec& spec, double t) = 0;
  // A text attribute of the whole run (HDF5: of the root group); CSV runs
  // have summary.json and write nothing.
  virtual void set_attribute(const std::string& name, const std::string& text) = 0;
};

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
// The events table of the run in `dir`, in either format.
std::vector<Event> read_run_events(const std::filesystem::path& dir);

// Readers of one CSV table (src/output/csv_tables.cpp); OutputError naming the
// file, with the line number for a malformed row.
TraceTable read_traces_csv(const std::filesystem::path& file);
NamedColumns read_columns_csv(const std::filesystem::path& file);
std::vector<Event> read_events_csv(const std::filesystem::path& file);

}  // namespace stickslip
