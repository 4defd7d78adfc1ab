#pragma once
// Turns a TOML case file into a validated Case. Every error names the file,
// the line, the key and what is wrong, in one line:
//     cases/x.toml:12: interface.coverage: must be in (0, 1], got 1.5
// and is thrown as CaseError (the command line exits with code 2 on it).

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "stickslip/case/case.hpp"

namespace stickslip {

class CaseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A section or key the schema does not have (the message suggests the
// nearest); the command line adds where every key is listed.
class UnknownKeyError : public CaseError {
 public:
  using CaseError::CaseError;
};

// Reads and validates `file`. `overrides` are "section.key=value" strings from
// `--set` (the value is TOML: 0.5, "navier", [1, 2]); they replace the file's
// values before validation, and errors in them are reported as "--set section.key".
// `override_origin` is that "--set": the Python module, whose overrides are a
// dict's keys, passes "" so that a message starts with the key itself.
Case read_case(const std::filesystem::path& file, const std::vector<std::string>& overrides = {},
               std::string_view override_origin = "--set");

// Same, from text already in memory; `source` is the name used in messages and
// the directory relative paths are resolved against.
Case parse_case(std::string_view toml_text, const std::filesystem::path& source,
                const std::vector<std::string>& overrides = {},
                std::string_view override_origin = "--set");

// Empty if "section.key" names a case key; otherwise why not, with the
// nearest valid name ("unknown key 'covrage' (did you mean 'coverage'?)").
std::string case_key_problem(std::string_view dotted_key);

}  // namespace stickslip
