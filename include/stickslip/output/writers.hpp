#pragma once
// Output files of a run. CSV rows are formatted with snprintf into a buffered
// stream; summary.json is written atomically (temporary file, then rename) so
// a reader never sees half of it.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace stickslip {

// An output directory that cannot be used (results would be overwritten, or
// it cannot be created); the command line exits with code 2 on it.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Creates `dir` if needed. Refuses (OutputError) when it already holds any of
// `result_files` and `overwrite` is false; with `overwrite`, removes only those.
void prepare_output_dir(const std::filesystem::path& dir, bool overwrite,
                        std::span<const std::string> result_files);

class CsvWriter {
 public:
  CsvWriter(const std::filesystem::path& file, const std::vector<std::string>& header);
  // Appends to an existing file (a restarted run), writing no header.
  static CsvWriter append(const std::filesystem::path& file);
  // One row: values printed with 10 significant digits (times with 12).
  void row(double t, std::span<const double> values);
  void line(std::string_view text) { out_ << text << '\n'; }
  // Values with 17 digits from here on, enough to read back every double.
  void full_precision() { value_format_ = ",%.17g"; }
  void flush() { out_.flush(); }

 private:
  CsvWriter() = default;
  std::ofstream out_;
  std::filesystem::path file_;
  const char* value_format_ = ",%.10g";
  char buffer_[32];
};

// Drops the rows of a CSV file (first column: time) after `t`, keeping the
// header: a restart continues from its checkpoint without duplicated rows.
void keep_rows_up_to(const std::filesystem::path& file, double t);

// Writes `file` whole or not at all: `write` fills a temporary file (named
// for this process, so concurrent writers never share one), which then
// replaces `file`. OutputError if it cannot be written.
void write_atomically(const std::filesystem::path& file,
                      const std::function<void(std::ostream&)>& write);
void write_json_atomically(const std::filesystem::path& file, const nlohmann::json& value);

}  // namespace stickslip
