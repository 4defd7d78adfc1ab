// A run's tables in CSV and in HDF5: the same rows either way, read back the
// same way, cut back and continued by a restart; a run in format "hdf5"
// holds the same numbers as the same run's CSV files.
#include <sys/resource.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../src/output/hdf5_tables.hpp"
#include "stickslip/analysis/compare.hpp"
#include "stickslip/case/reader.hpp"
#include "stickslip/output/summary.hpp"
#include "stickslip/output/tables.hpp"
#include "stickslip/output/writers.hpp"
#include "stickslip/run/run.hpp"
#include "temp_dir.hpp"
#include "test_cases.hpp"

namespace fs = std::filesystem;
using namespace stickslip;

namespace {

using Columns = std::map<std::string, std::vector<double>>;

// A CSV file's columns by header name, parsed here (not by the code under
// test); the events' kind text as EventKind's number.
Columns csv_columns(const fs::path& file) {
  std::ifstream in(file);
  REQUIRE(in);
  std::string line, field;
  std::getline(in, line);
  std::vector<std::string> header;
  for (std::istringstream fields(line); std::getline(fields, field, ',');) header.push_back(field);
  Columns columns;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    for (const auto& name : header) {
      REQUIRE(std::getline(fields, field, ','));
      const double value = field == "slip"    ? 0.0
                           : field == "stick" ? 1.0
                                              : std::strtod(field.c_str(), nullptr);
      columns[name].push_back(value);
    }
  }
  return columns;
}

Columns hdf5_columns(const fs::path& file, const std::string& table) {
  Columns columns;
  for (auto& [name, values] : read_hdf5_table(file, table)) columns[name] = std::move(values);
  return columns;
}

// Whether `printed` is `exact` printed to at least 10 significant digits.
bool same_number(double exact, double printed) {
  if (std::isnan(exact)) return std::isnan(printed);
  return std::abs(printed - exact) <= 5.0001e-10 * std::abs(exact);
}

// A spec of every kind of column read_run_table reads: time, an integer and a
// 2-D pair whose members are listed out of order. (Label columns, the
// events' kind, are read by read_run_events: tested with whole runs.)
TableSpec test_spec() {
  TableSpec spec{"probe", {{.name = "t", .unit = "s", .digits = 12}}, "contact", {7, 3}};
  spec.columns.push_back({.name = "n", .type = ColumnType::integer});
  for (int k = 0; k < 2; ++k)
    for (const char* axis : {"vx", "vy"})
      spec.columns.push_back({.name = std::string(axis) + "_" + std::to_string(spec.members[k]),
                              .unit = "m/s",
                              .dataset = axis,
                              .member = k});
  return spec;
}

std::vector<double> test_row(long k) {
  return {1e-4 * static_cast<double>(k), static_cast<double>(k % 5), std::sin(0.1 * k),
          -1e-9 * std::cos(0.3 * k),     std::exp(-1e-3 * k),        1e17 * k};
}

}  // namespace

TEST_CASE("a table reads back the same from CSV and HDF5, also after a restart's cut", "[tables]") {
  const TableSpec spec = test_spec();
  // More rows than one HDF5 write block (4096), with a flush in between.
  const long rows = 5000, kept = 3000, more = 1200;
  for (const OutputFormat format : {OutputFormat::csv, OutputFormat::hdf5}) {
    INFO(to_string(format));
    const test::TempDir tmp(std::string("stickslip_test_tables_") + to_string(format));
    const fs::path& dir = tmp.path;
    {
      const auto store = make_table_store(format, dir, false);
      const auto table = store->create(spec);
      for (long k = 0; k < rows; ++k) {
        table->append(test_row(k));
        if (k == 2500) table->flush();
      }
      table->flush();
    }
    CHECK(has_run_table(dir, "probe"));
    CHECK_FALSE(has_run_table(dir, "absent"));
    // A restart at row kept's time: later rows go, new ones follow.
    {
      const auto store = make_table_store(format, dir, true);
      const auto table = store->resume(spec, 1e-4 * kept);
      for (long k = kept + 1; k <= kept + more; ++k) table->append(test_row(k));
      table->flush();
    }
    const TraceTable read = read_run_table(dir, "probe");
    REQUIRE(read.t.size() == static_cast<std::size_t>(kept + more + 1));
    // Columns by their CSV names, 2-D members named by their ids.
    std::map<std::string, std::size_t> index;
    for (std::size_t c = 0; c < read.columns.size(); ++c) index[read.columns[c]] = c;
    CHECK(index.size() == 5);
    const std::vector<std::string> names{"n", "vx_7", "vy_7", "vx_3", "vy_3"};
    for (std::size_t k = 0; k < read.t.size(); ++k) {
      const auto expected = test_row(static_cast<long>(k));
      REQUIRE(same_number(expected[0], read.t[k]));
      for (std::size_t c = 0; c < names.size(); ++c) {
        REQUIRE(index.count(names[c]));
        const double value = read.values[index[names[c]]][k];
        // HDF5 keeps every double; CSV prints 10 digits.
        if (format == OutputFormat::hdf5)
          REQUIRE(value == expected[c + 1]);
        else
          REQUIRE(same_number(expected[c + 1], value));
      }
    }
  }
}

TEST_CASE("events, with their label column, read back the same from CSV and HDF5", "[tables]") {
  const TableSpec spec{"events",
                       {{.name = "t", .digits = 15},
                        {.name = "contact", .type = ColumnType::integer},
                        {.name = "kind", .type = ColumnType::label, .labels = {"slip", "stick"}},
                        {.name = "speed"},
                        {.name = "force"}}};
  // Two contacts slipping at the same instant, as root finding may report.
  const std::vector<Event> written{{1e-4, 0, EventKind::slip, 1.5e-3, 2e-2},
                                   {1e-4, 3, EventKind::slip, 2.5e-3, 3e-2},
                                   {2.25e-4, 0, EventKind::stick, 4.75e-4, 1e-2}};
  for (const OutputFormat format : {OutputFormat::csv, OutputFormat::hdf5}) {
    INFO(to_string(format));
    const test::TempDir tmp(std::string("stickslip_test_events_") + to_string(format));
    const fs::path& dir = tmp.path;
    {
      const auto table = make_table_store(format, dir, false)->create(spec);
      for (const Event& e : written) {
        const double row[5] = {e.t, double(e.contact), double(static_cast<int>(e.kind)), e.speed,
                               e.force};
        table->append(row);
      }
      table->flush();
    }
    const auto read = read_run_events(dir);
    REQUIRE(read.size() == written.size());
    for (std::size_t k = 0; k < read.size(); ++k) {
      CHECK(read[k].t == written[k].t);
      CHECK(read[k].contact == written[k].contact);
      CHECK(read[k].kind == written[k].kind);
      CHECK(same_number(written[k].speed, read[k].speed));
      CHECK(same_number(written[k].force, read[k].force));
    }
    // A restart before the first event keeps none of them.
    {
      const auto table = make_table_store(format, dir, true)->resume(spec, 5e-5);
      table->flush();
    }
    CHECK(read_run_events(dir).empty());
  }
}

TEST_CASE("a run's table that cannot be read back is an output error naming the file and line",
          "[tables]") {
  // A restart reads its own tables back: one it cannot read leaves the output
  // directory unusable (OutputError, exit code 2), not a failed comparison.
  const test::TempDir tmp("stickslip_test_tables_bad");
  std::ofstream(tmp.path / "friction.csv") << "t,F_f,mu_inst\n0,0,0\n1e-05,1,2\n1e-05,1,2\n";
  try {
    read_run_table(tmp.path, "friction");
    FAIL("read a table whose time does not increase");
  } catch (const OutputError& e) {
    CHECK_THAT(e.what(), Catch::Contains((tmp.path / "friction.csv").string()) &&
                             Catch::Contains("line 4: time does not increase"));
  }
  std::ofstream(tmp.path / "events.csv") << "t,contact,kind\n1e-05,0,slide\n";
  CHECK_THROWS_AS(read_run_events(tmp.path), OutputError);
}

TEST_CASE("a row a running run is still writing is left out, a malformed whole row is not",
          "[tables]") {
  const test::TempDir tmp("stickslip_test_tables_running");
  // The writer ends every row with a newline; the last line has none while it is written.
  std::ofstream(tmp.path / "friction.csv") << "t,F_f,mu_inst\n0,0,0\n1e-06,1,2\n2e-06,1.5";
  const TraceTable table = read_run_table(tmp.path, "friction");
  CHECK(table.t == std::vector<double>{0, 1e-06});
  const NamedColumns columns = read_run_columns(tmp.path, "friction");
  REQUIRE(columns.size() == 3);
  CHECK(columns[0].first == "t");
  CHECK(columns[2].second == std::vector<double>{0, 2});
  std::ofstream(tmp.path / "friction.csv") << "t,F_f,mu_inst\n0,0,0\n1e-06,1,2\n2e-06,1.5\n";
  CHECK_THROWS_WITH(read_run_table(tmp.path, "friction"),
                    Catch::Contains("line 4: 2 fields, header has 3"));
}

TEST_CASE("a resumed table that does not exist is an output error naming it", "[tables]") {
  for (const OutputFormat format : {OutputFormat::csv, OutputFormat::hdf5}) {
    const test::TempDir tmp(std::string("stickslip_test_tables_missing_") + to_string(format));
    const fs::path& dir = tmp.path;
    make_table_store(format, dir, false);  // creates run.h5 (empty) in HDF5
    const auto store = make_table_store(format, dir, true);
    CHECK_THROWS_AS(store->resume(test_spec(), 0.0), OutputError);
    try {
      store->resume(test_spec(), 0.0);
    } catch (const OutputError& e) {
      CHECK_THAT(e.what(), Catch::Contains("probe"));
    }
  }
}

TEST_CASE("a run in format hdf5 holds the same numbers as the same run's CSV files",
          "[slow][tables]") {
  const test::TempDir tmp("stickslip_test_hdf5_run");
  const fs::path& box = tmp.path;
  // Every output on: two contacts that stick and slip on a small lattice.
  const std::string text = std::string(stickslip::test::kTwoContactToml) + R"([run]
t_end = 1e-3
average_from = 2e-4
[output]
interval = 2e-6
traces = "all"
signals = true
steps = true
final_state = true
)";
  std::map<std::string, fs::path> dirs;
  for (const char* format : {"csv", "hdf5"}) {
    const Case c = parse_case(text + "format = \"" + format + "\"\n", box / "probe.toml");
    RunOptions options;
    options.out_dir = dirs[format] = box / format;
    options.quiet = true;
    run_case(c, options);
  }
  const fs::path h5 = dirs["hdf5"] / kHdf5File;
  REQUIRE(fs::exists(h5));
  for (const char* name : {"friction.csv", "traces.csv", "events.csv", "steps.csv", "contacts.csv",
                           "signals.csv", "final_state.csv"}) {
    CHECK_FALSE(fs::exists(dirs["hdf5"] / name));
    const std::string table = fs::path(name).stem().string();
    INFO(table);
    const Columns csv = csv_columns(dirs["csv"] / name);
    const Columns hdf5 = hdf5_columns(h5, table);
    REQUIRE(hdf5.size() == csv.size());
    for (const auto& [column, printed] : csv) {
      INFO(column);
      REQUIRE(hdf5.count(column));
      const auto& exact = hdf5.at(column);
      REQUIRE(exact.size() == printed.size());
      CHECK(exact.size() > 1);
      for (std::size_t k = 0; k < exact.size(); ++k) REQUIRE(same_number(exact[k], printed[k]));
    }
  }
  // The summary as the root attribute, the same as summary.json; and the
  // case and provenance beside it.
  const Summary from_file = *read_summary(dirs["hdf5"]);
  std::ifstream summary_json(dirs["hdf5"] / kSummaryFile);
  CHECK(nlohmann::json::parse(read_hdf5_attribute(h5, "summary")) ==
        nlohmann::json::parse(summary_json));
  CHECK(nlohmann::json::parse(read_hdf5_attribute(h5, "case")) == from_file.case_json);
  CHECK(read_hdf5_attribute(h5, "git_commit") == from_file.git_commit);
  // The same run: μ from the same integration, bit for bit; and the
  // statistics of F_f's samples from the samples as computed, not as one
  // format prints them.
  const Summary from_csv = *read_summary(dirs["csv"]);
  CHECK(from_csv.mu == from_file.mu);
  REQUIRE(from_csv.mu_whole_cycles);
  REQUIRE(from_file.mu_whole_cycles);
  CHECK(from_csv.mu_whole_cycles->mu == from_file.mu_whole_cycles->mu);
  CHECK(from_csv.F_f_spread == from_file.F_f_spread);
}

TEST_CASE("an exact column is written in the fewest digits that read back bit for bit",
          "[tables]") {
  const test::TempDir tmp("stickslip_test_exact_digits");
  const TableSpec spec{"exact", {{.name = "t", .unit = "s"}, {.name = "v", .digits = kExact}}};
  // 2.09e-3 printed to 17 digits is 0.0020899999999999998; 0.1 + 0.2 needs all 17.
  const std::vector<double> values = {2.09e-3, 0.1 + 0.2, 1.0 / 3.0, -4.75e-4, 1e-300};
  {
    const auto table = make_table_store(OutputFormat::csv, tmp.path, false)->create(spec);
    for (std::size_t k = 0; k < values.size(); ++k) {
      const double row[2] = {double(k), values[k]};
      table->append(row);
    }
  }
  std::ifstream in(tmp.path / "exact.csv");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK_THAT(text, Catch::Contains("\n0,0.00209\n") &&
                       Catch::Contains("\n1,0.30000000000000004\n") &&
                       Catch::Contains("\n3,-0.000475\n"));
  const TraceTable back = read_run_table(tmp.path, "exact");
  REQUIRE(back.values.at(0).size() == values.size());
  for (std::size_t k = 0; k < values.size(); ++k) CHECK(back.values[0][k] == values[k]);
}

TEST_CASE(
    "a write the OS refuses says why, keeps the file it would replace, and leaves no "
    "temporary file",
    "[tables]") {
  // A real refusal: a file-size limit below what is written makes write(2)
  // fail with EFBIG, as a full disk makes it fail with ENOSPC.
  test::TempDir dir("stickslip_test_write_refused");
  const auto file = dir.path / "summary.json";
  write_atomically(file, [](std::ostream& out) { out << "kept\n"; });
  rlimit before{};
  REQUIRE(getrlimit(RLIMIT_FSIZE, &before) == 0);
  const auto previous = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = before;
  small.rlim_cur = 4096;
  REQUIRE(setrlimit(RLIMIT_FSIZE, &small) == 0);
  std::string message;
  try {
    write_atomically(file, [](std::ostream& out) { out << std::string(1 << 20, 'x'); });
  } catch (const OutputError& e) {
    message = e.what();
  }
  REQUIRE(setrlimit(RLIMIT_FSIZE, &before) == 0);
  std::signal(SIGXFSZ, previous);
  CHECK_THAT(message, Catch::Contains("write failed: File too large"));
  std::ifstream in(file);
  std::string kept;
  std::getline(in, kept);
  CHECK(kept == "kept");
  for (const auto& entry : std::filesystem::directory_iterator(dir.path))
    CHECK(entry.path().extension() != ".tmp");
  // A writer that throws leaves no temporary file either.
  CHECK_THROWS(write_atomically(file, [](std::ostream&) { throw std::runtime_error("stop"); }));
  for (const auto& entry : std::filesystem::directory_iterator(dir.path))
    CHECK(entry.path().extension() != ".tmp");
}
