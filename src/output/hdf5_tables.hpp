#pragma once
// The HDF5 store of a run's tables (one file, a group per table), which
// output/tables.hpp's make_table_store and readers call; kept apart so only
// this file and hdf5_tables.cpp see the HDF5 C API.

#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "stickslip/output/table_store.hpp"

namespace stickslip {

// The store of a run in `format = "hdf5"`: `file` created (replacing any) or,
// on a restart, opened for appending. OutputError if it cannot be.
std::unique_ptr<TableStore> make_hdf5_store(const std::filesystem::path& file, bool resume);

// Whether `file` has the table (group) `name`. OutputError if it is not an HDF5 file.
bool hdf5_has_table(const std::filesystem::path& file, const std::string& name);

// Every column of table `name` in `file` by its CSV name, in the order the
// datasets were created (a 2-D dataset as one column per member). OutputError
// if the file or table is missing or malformed.
std::vector<std::pair<std::string, std::vector<double>>> read_hdf5_table(
    const std::filesystem::path& file, const std::string& name);

// The text attribute `name` of the root group of `file` ("" if it has none).
// OutputError if the file cannot be opened.
std::string read_hdf5_attribute(const std::filesystem::path& file, const std::string& name);

}  // namespace stickslip
