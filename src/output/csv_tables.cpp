#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string_view>
#include <system_error>

#include "stickslip/output/tables.hpp"
#include "stickslip/output/writers.hpp"

// Readers of a run's CSV tables. A run reads its own tables back on restart
// (output/recorders.cpp), and `stickslip compare` reads two runs' (analysis/
// compare.cpp, which reports their errors as its own); an unreadable table is
// an unusable output directory: OutputError, exit code 2.

namespace stickslip {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const fs::path& file, const std::string& why) {
  throw OutputError(file.string() + ": " + why);
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> fields;
  for (;;) {
    const auto comma = line.find(',');
    fields.push_back(trim(line.substr(0, comma)));
    if (comma == std::string_view::npos) return fields;
    line.remove_prefix(comma + 1);
  }
}

// A CSV file as a header and rows of fields, with the line number of each row
// for messages. Blank lines are skipped; every row must have the header's
// number of fields. A last line without its newline is a row a running run
// is still writing (the writers end every row with one): it is left out.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::vector<long> line_numbers;
};

Csv read_csv(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) fail(file, "not a regular file");
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, "cannot open for reading");
  Csv csv;
  std::string line;
  long number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (in.eof() && !csv.header.empty()) break;  // no newline: still being written
    if (trim(line).empty()) continue;
    const auto fields = split(line);
    if (csv.header.empty()) {
      for (auto f : fields) csv.header.emplace_back(f);
      continue;
    }
    if (fields.size() != csv.header.size())
      fail(file, "line " + std::to_string(number) + ": " + std::to_string(fields.size()) +
                     " fields, header has " + std::to_string(csv.header.size()));
    csv.rows.emplace_back(fields.begin(), fields.end());
    csv.line_numbers.push_back(number);
  }
  if (in.bad()) fail(file, "read error");
  if (csv.header.empty()) fail(file, "empty file (no header)");
  return csv;
}

double parse_double(const fs::path& file, long line, std::string_view text) {
  double x = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty())
    fail(file, "line " + std::to_string(line) + ": \"" + std::string(text) + "\" is not a number");
  return x;
}

int parse_int(const fs::path& file, long line, std::string_view text) {
  int x = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty())
    fail(file,
         "line " + std::to_string(line) + ": \"" + std::string(text) + "\" is not an integer");
  return x;
}

std::ptrdiff_t column_index(const Csv& csv, const fs::path& file, const std::string& name,
                            bool required) {
  const auto it = std::find(csv.header.begin(), csv.header.end(), name);
  if (it == csv.header.end()) {
    if (required) fail(file, "no column \"" + name + "\" in the header");
    return -1;
  }
  return it - csv.header.begin();
}

}  // namespace

TraceTable read_traces_csv(const fs::path& file) {
  const Csv csv = read_csv(file);
  if (csv.header.front() != "t") fail(file, "the first column is not \"t\"");
  TraceTable table;
  table.columns.assign(csv.header.begin() + 1, csv.header.end());
  table.values.assign(table.columns.size(), {});
  for (auto& v : table.values) v.reserve(csv.rows.size());
  table.t.reserve(csv.rows.size());
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    const long line = csv.line_numbers[i];
    const double t = parse_double(file, line, csv.rows[i][0]);
    // Interpolation needs increasing times; a repeated or NaN time is corrupt.
    if (!std::isfinite(t) || (!table.t.empty() && !(t > table.t.back())))
      fail(file, "line " + std::to_string(line) + ": time does not increase");
    table.t.push_back(t);
    for (std::size_t c = 0; c < table.columns.size(); ++c)
      table.values[c].push_back(parse_double(file, line, csv.rows[i][c + 1]));
  }
  return table;
}

NamedColumns read_columns_csv(const fs::path& file) {
  const Csv csv = read_csv(file);
  NamedColumns columns;
  for (const auto& name : csv.header) columns.emplace_back(name, std::vector<double>{});
  for (std::size_t i = 0; i < csv.rows.size(); ++i)
    for (std::size_t c = 0; c < columns.size(); ++c)
      columns[c].second.push_back(parse_double(file, csv.line_numbers[i], csv.rows[i][c]));
  return columns;
}

std::vector<Event> read_events_csv(const fs::path& file) {
  const Csv csv = read_csv(file);
  // Columns by name, so a writer that adds columns does not break the reader.
  const auto ct = column_index(csv, file, "t", true);
  const auto cc = column_index(csv, file, "contact", true);
  const auto ck = column_index(csv, file, "kind", true);
  const auto cs = column_index(csv, file, "speed", false);
  const auto cf = column_index(csv, file, "force", false);
  std::vector<Event> events;
  events.reserve(csv.rows.size());
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    const long line = csv.line_numbers[i];
    const auto& row = csv.rows[i];
    Event e;
    e.t = parse_double(file, line, row[static_cast<std::size_t>(ct)]);
    if (!std::isfinite(e.t)) fail(file, "line " + std::to_string(line) + ": time is not finite");
    e.contact = parse_int(file, line, row[static_cast<std::size_t>(cc)]);
    const auto kind = parse_event_kind(row[static_cast<std::size_t>(ck)]);
    if (!kind)
      fail(file, "line " + std::to_string(line) + ": kind \"" + row[static_cast<std::size_t>(ck)] +
                     "\" is neither slip nor stick");
    e.kind = *kind;
    if (cs >= 0) e.speed = parse_double(file, line, row[static_cast<std::size_t>(cs)]);
    if (cf >= 0) e.force = parse_double(file, line, row[static_cast<std::size_t>(cf)]);
    events.push_back(e);
  }
  return events;
}

}  // namespace stickslip
