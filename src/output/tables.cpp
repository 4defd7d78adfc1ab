// The CSV store of a run's tables, and reading a run's tables back in either
// format (the HDF5 store is in hdf5_tables.cpp).
#include "stickslip/output/tables.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "hdf5_tables.hpp"
#include "stickslip/output/writers.hpp"

namespace stickslip {

const std::vector<double>& TraceTable::column(std::string_view name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  if (it == columns.end())
    throw OutputError("a table read back has no column \"" + std::string(name) + "\"");
  return values[static_cast<std::size_t>(it - columns.begin())];
}

namespace {

namespace fs = std::filesystem;

// A CSV table's header line (without its newline): the column names.
std::string csv_header(const std::vector<Column>& columns) {
  std::string header;
  for (std::size_t i = 0; i < columns.size(); ++i) header += (i ? "," : "") + columns[i].name;
  return header;
}

// A table as a CSV file: the header, then a row per line; each value printed
// as its column says (reals with the column's significant digits).
class CsvTable final : public Table {
 public:
  CsvTable(const TableSpec& spec, const fs::path& file, bool append) : columns_(spec.columns) {
    out_.open(file, append ? std::ios::app : std::ios::trunc);
    if (!out_)
      throw OutputError(file.string() + ": cannot open for " + (append ? "appending" : "writing"));
    for (const Column& c : columns_) formats_.push_back("%." + std::to_string(c.digits) + "g");
    if (append) return;
    out_ << csv_header(columns_) << '\n';
  }
  void append(std::span<const double> row) override {
    check_row(row, columns_.size());
    for (std::size_t i = 0; i < columns_.size(); ++i) {
      if (i) out_ << ',';
      const Column& c = columns_[i];
      switch (c.type) {
        case ColumnType::real:
          if (c.digits == kExact) {
            const auto end = std::to_chars(buffer_, buffer_ + sizeof buffer_, row[i]).ptr;
            out_.write(buffer_, end - buffer_);
          } else {
            std::snprintf(buffer_, sizeof buffer_, formats_[i].c_str(), row[i]);
            out_ << buffer_;
          }
          break;
        case ColumnType::integer:
          out_ << std::llround(row[i]);
          break;
        case ColumnType::label:
          out_ << c.labels.at(static_cast<std::size_t>(std::llround(row[i])));
          break;
      }
    }
    out_ << '\n';
  }
  void flush() override { out_.flush(); }

 private:
  std::vector<Column> columns_;
  std::vector<std::string> formats_;
  std::ofstream out_;
  char buffer_[40];
};

class CsvStore final : public TableStore {
 public:
  explicit CsvStore(fs::path dir) : dir_(std::move(dir)) {}
  std::unique_ptr<Table> create(const TableSpec& spec) override {
    return std::make_unique<CsvTable>(spec, file(spec), false);
  }
  std::unique_ptr<Table> resume(const TableSpec& spec, double t) override {
    if (!fs::exists(file(spec)))
      throw OutputError(file(spec).string() + ": missing; the run cannot continue without it");
    // Rows of other columns would follow its header unnoticed (a build whose
    // table has a column more or less: steps.csv of multirate).
    std::string header;
    std::ifstream in(file(spec));
    std::getline(in, header);
    const std::string expected = csv_header(spec.columns);
    if (header != expected)
      throw OutputError(file(spec).string() + ": its columns are " + header +
                        ", where this build writes " + expected +
                        "; continue the run with the build that wrote it");
    keep_rows_up_to(file(spec), t);
    return std::make_unique<CsvTable>(spec, file(spec), true);
  }
  void set_attribute(const std::string&, const std::string&) override {}

 private:
  fs::path file(const TableSpec& spec) const { return dir_ / csv_file_name(spec.name); }
  fs::path dir_;
};

fs::path csv_file(const fs::path& dir, const std::string& name) {
  return dir / csv_file_name(name);
}

bool is_hdf5_run(const fs::path& dir) {
  return fs::exists(dir / kHdf5File);
}

}  // namespace

std::unique_ptr<TableStore> make_table_store(OutputFormat format, const fs::path& dir,
                                             bool resume) {
  if (format == OutputFormat::hdf5) return make_hdf5_store(dir / kHdf5File, resume);
  return std::make_unique<CsvStore>(dir);
}

bool has_run_table(const fs::path& dir, const std::string& name) {
  if (is_hdf5_run(dir)) return hdf5_has_table(dir / kHdf5File, name);
  std::error_code ec;
  return fs::is_regular_file(csv_file(dir, name), ec);
}

TraceTable read_run_table(const fs::path& dir, const std::string& name) {
  if (!is_hdf5_run(dir)) return read_traces_csv(csv_file(dir, name));
  const fs::path file = dir / kHdf5File;
  auto columns = read_hdf5_table(file, name);
  const std::string where = file.string() + ": /" + name;
  if (columns.empty() || columns.front().first != "t")
    throw OutputError(where + ": the first dataset is not \"t\"");
  TraceTable table;
  table.t = std::move(columns.front().second);
  for (std::size_t i = 0; i < table.t.size(); ++i)
    if (!std::isfinite(table.t[i]) || (i > 0 && !(table.t[i] > table.t[i - 1])))
      throw OutputError(where + "/t: row " + std::to_string(i) + ": time does not increase");
  for (std::size_t c = 1; c < columns.size(); ++c) {
    table.columns.push_back(std::move(columns[c].first));
    table.values.push_back(std::move(columns[c].second));
  }
  return table;
}

NamedColumns read_run_columns(const fs::path& dir, const std::string& name) {
  if (!is_hdf5_run(dir)) return read_columns_csv(csv_file(dir, name));
  return read_hdf5_table(dir / kHdf5File, name);
}

std::optional<double> last_row_time(const fs::path& dir, const std::string& name, double t) {
  // Times are printed to 12 digits or more, so the row at t itself may read
  // back a little above it (as keep_rows_up_to allows).
  const double up_to = t * (1 + 1e-10);
  std::optional<double> last;
  if (is_hdf5_run(dir)) {
    const auto columns = read_run_columns(dir, name);
    if (columns.empty()) throw OutputError(run_table_location(dir, name) + ": has no columns");
    for (const double ti : columns.front().second) {
      if (ti > up_to) break;
      last = ti;
    }
    return last;
  }
  const fs::path file = csv_file(dir, name);
  std::ifstream in(file);
  if (!in) throw OutputError(file.string() + ": missing; the run cannot continue without it");
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    if (in.eof()) break;  // cut off mid-write
    const double ti = std::strtod(line.c_str(), nullptr);
    if (ti > up_to) break;
    last = ti;
  }
  return last;
}

std::string run_table_location(const fs::path& dir, const std::string& name) {
  if (is_hdf5_run(dir)) return (dir / kHdf5File).string() + ": /" + name;
  return csv_file(dir, name).string();
}

std::vector<Event> read_run_events(const fs::path& dir) {
  if (!is_hdf5_run(dir)) return read_events_csv(csv_file(dir, run_table::kEvents));
  const fs::path file = dir / kHdf5File;
  const auto columns = read_hdf5_table(file, run_table::kEvents);
  auto column = [&](const char* name) -> const std::vector<double>* {
    for (const auto& [n, values] : columns)
      if (n == name) return &values;
    return nullptr;
  };
  const auto *t = column("t"), *contact = column("contact"), *kind = column("kind");
  if (!t || !contact || !kind)
    throw OutputError(file.string() + ": /events: needs the datasets t, contact and kind");
  const auto *speed = column("speed"), *force = column("force");
  std::vector<Event> events(t->size());
  for (std::size_t i = 0; i < events.size(); ++i) {
    Event& e = events[i];
    e.t = (*t)[i];
    if (!std::isfinite(e.t))
      throw OutputError(file.string() + ": /events/t: row " + std::to_string(i) +
                        ": time is not finite");
    e.contact = static_cast<int>((*contact)[i]);
    if (e.contact != (*contact)[i] || e.contact < 0)
      throw OutputError(file.string() + ": /events/contact: row " + std::to_string(i) +
                        ": not a contact id");
    const double k = (*kind)[i];
    if (k != static_cast<double>(EventKind::slip) && k != static_cast<double>(EventKind::stick))
      throw OutputError(file.string() + ": /events/kind: row " + std::to_string(i) +
                        " is neither slip nor stick");
    e.kind = static_cast<EventKind>(static_cast<int>(k));
    if (speed) e.speed = (*speed)[i];
    if (force) e.force = (*force)[i];
  }
  return events;
}

}  // namespace stickslip
