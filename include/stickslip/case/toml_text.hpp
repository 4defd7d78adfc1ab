#pragma once
// TOML text for the case and sweep readers (src/case and
// src/sweep/sweep_reader.cpp; not the library's interface): parsing
// with the guard against toml++ 3.3's undefined behaviour on non-ASCII
// input, and the wording helpers of one-line error messages.

#include <toml++/toml.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace stickslip::toml_text {

// A TOML syntax error, from toml++ or from parse_toml's own lexer.
struct TomlSyntaxError {
  std::string description;
  std::uint32_t line;
};

// Parses `text` (messages name `source`), a leading byte-order mark left out;
// throws TomlSyntaxError.
toml::table parse_toml(std::string_view text, std::string_view source);

// The fewest %g digits that read back as x: 0.0005, 1e-12, 0.1.
std::string fmt(double x);
// User text for one-line messages: control characters escaped.
std::string printable(std::string_view s);
// toml++'s name of a node's type: integer, floating-point, string, array, ...
std::string type_name(const toml::node& n);
// " (did you mean 'x'?)" when `name` is close to a valid one, else " (valid: ...)".
std::string suggest(std::string_view name, const std::vector<std::string_view>& valid);

}  // namespace stickslip::toml_text
