#pragma once
// Output files of a run (its tables are in output/tables.hpp): the output
// directory, cutting a CSV table back for a restart, and writing a file
// atomically (temporary file, then rename) so a reader never sees half of
// summary.json.

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <span>
#include <stdexcept>
#include <string>
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
