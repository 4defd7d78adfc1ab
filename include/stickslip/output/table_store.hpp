#pragma once
// What both stores of a run's tables (CSV files, tables.cpp; one HDF5 file,
// hdf5_tables.cpp) share, beneath both: how a recorder describes its table
// (TableSpec), the interface a store implements, and the rules both follow
// (a row's width, the names of a table's file and of a 2-D dataset's
// members). Which store a run uses, and reading tables back, is tables.hpp.

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace stickslip {

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

// A store that hands everything to another and notes, table by table, the
// time of the rows appended (the first column, where it is a time: unit
// "s"), so that a checkpoint records how far each table reached.
class TrackedTableStore final : public TableStore {
 public:
  // `reached`: on a restart, what its checkpoint recorded (last_rows): where
  // each table ends until it has new rows.
  explicit TrackedTableStore(std::unique_ptr<TableStore> store,
                             const std::map<std::string, double>& reached = {});
  std::unique_ptr<Table> create(const TableSpec& spec) override;
  std::unique_ptr<Table> resume(const TableSpec& spec, double t) override;
  void set_attribute(const std::string& name, const std::string& text) override;
  // By table, the time of its last row at or before `t` (a step that ended
  // past a checkpoint's time has a row after it, which the restart cuts);
  // a table without one is left out. From what the store noted, not the files.
  std::map<std::string, double> last_rows(double t) const;

 private:
  std::unique_ptr<TableStore> store_;
  // By table, the times of its last few rows, the newest last: enough for
  // the rows of one step past any time asked about.
  std::map<std::string, std::deque<double>> recent_;
};

// A recorder's row has a value per column (std::logic_error otherwise); both
// stores check it.
void check_row(std::span<const double> row, std::size_t columns);

}  // namespace stickslip
