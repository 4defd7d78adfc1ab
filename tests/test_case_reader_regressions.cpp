// Inputs that once broke the case-file reader, from scripts/fuzz (libFuzzer with
// ASan/UBSan) and by hand. Each must be refused with a CaseError (or parse to
// the right value); before the fix the first ones ran into undefined behaviour
// inside toml++ 3.3.0 (__builtin_unreachable in is_non_ascii_horizontal_whitespace).
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "stickslip/case/reader.hpp"

using Catch::Contains;
using stickslip::CaseError;
using stickslip::parse_case;

namespace {

std::string refusal(const std::string& text, const std::vector<std::string>& sets = {}) {
  try {
    parse_case(text, "fuzz.toml", sets);
  } catch (const CaseError& e) {
    return e.what();
  }
  FAIL("accepted: " << text);
  return {};
}

}  // namespace

TEST_CASE("a non-ASCII character outside strings and comments is malformed TOML", "[case][bugs]") {
  // Found by the fuzzer (minimized): '§' (U+00A7) after a value, and in a bare value
  // that toml++ reads through a quote.
  CHECK(refusal("[lattice]\nnx = 3 \xc2\xa7\n") ==
        "fuzz.toml:2: malformed TOML: unexpected character U+00A7 outside a string or comment");
  CHECK(refusal("[lattice]\nnz = 4'\xf1\xa4\x96\x91'\n") ==
        "fuzz.toml:2: malformed TOML: unexpected character U+64591 outside a string or comment");
  CHECK(refusal("[lattice]\nnx = 1.'\xc3\xa9'\n") ==
        "fuzz.toml:2: malformed TOML: unexpected character U+00E9 outside a string or comment");
  CHECK(refusal("\xc2\xa7 = 1\n") ==
        "fuzz.toml:1: malformed TOML: unexpected character U+00A7 outside a string or comment");
  // An earlier error is reported first.
  CHECK(refusal("[lattice]\nnx = = 3\nny = 3 \xc2\xa7\n") ==
        "fuzz.toml:2: malformed TOML: Error while parsing value: could not determine value type");
  // The same through --set.
  CHECK(refusal("", {"output.dir=\xc2\xa7"}) ==
        "--set output.dir: malformed TOML value '\xc2\xa7': unexpected character U+00A7 outside "
        "a string or comment");
}

TEST_CASE("a non-ASCII character after a backslash in a multi-line string", "[case][bugs]") {
  // An invalid escape: refused.
  CHECK(refusal("[output]\ndir = \"\"\"a\\\xc2\xa7\"\"\"\n") ==
        "fuzz.toml:2: malformed TOML: unknown escape sequence '\\\xc2\xa7' (U+00A7)");
  // After a line-ending backslash: valid TOML, and it means what it says.
  const auto c =
      parse_case("[output]\ndir = \"\"\"\\\n   \xc2\xa7x\\\n\xc3\xa9\"\"\"\n", "fuzz.toml");
  CHECK(c.output.dir == "\xc2\xa7x\xc3\xa9");
  // Non-ASCII text in strings and comments is fine everywhere else.
  const auto d = parse_case(
      "# \xc2\xa7 comment\n[output] # \xc2\xa7\ndir = 'r\xc3\xa9sultats'\n"
      "[interface]\ncontacts = [ # \xc2\xa7\n  { site = [1, 1], v_star = 1e-2 },\n]\n",
      "fuzz.toml");
  CHECK(d.output.dir == "r\xc3\xa9sultats");
  CHECK(d.interface.contacts.size() == 1);
}

TEST_CASE("nasty case files are refused cleanly", "[case][bugs]") {
  // toml++ asserts on this one in debug builds (upstream #294); release builds report it.
  CHECK_THAT(refusal("[&"), Contains("fuzz.toml:1: malformed TOML: "));
  // Deep nesting stops at toml++'s depth limit.
  CHECK_THAT(refusal("[output]\ntraces = " + std::string(5000, '[') + "\n"),
             Contains("fuzz.toml:2: malformed TOML: "));
  CHECK_THAT(refusal("[output]\ntraces = " + std::string(5000, '{') + "\n"),
             Contains("fuzz.toml:2: malformed TOML: "));
  // Huge integers.
  CHECK_THAT(refusal("[lattice]\nnx = 99999999999999999999\n"),
             Contains("fuzz.toml:2: malformed TOML: "));
  CHECK(refusal("[lattice]\nnx = 9223372036854775807\n") ==
        "fuzz.toml:2: lattice.nx: must be <= 2147483647, got 9223372036854775807");
  CHECK(refusal("[interface]\ncontacts = [ { site = [-9223372036854775808, 0], v_star = 1 } ]\n") ==
        "fuzz.toml:2: interface.contacts[0].site: must be >= 0, got -9223372036854775808");
  // NUL bytes and invalid UTF-8, in a value and in a comment.
  CHECK_THAT(refusal(std::string("[lattice]\nnx = 3\0\n", 17)),
             Contains("fuzz.toml:2: malformed TOML: "));
  CHECK(refusal("[lattice]\nnx = 3 # \xff\xfe\n") ==
        "fuzz.toml:2: malformed TOML: invalid UTF-8 (byte 0xff)");
  CHECK(refusal("[output]\ndir = \"\xc0\xaf\"\n") ==
        "fuzz.toml:2: malformed TOML: invalid UTF-8 (byte 0xc0)");
  // A key given twice through dotted keys, in --set style.
  CHECK_THAT(refusal("lattice.nx = 3\nlattice.nx = 4\n"),
             Contains("fuzz.toml:2: malformed TOML: "));
  CHECK_THAT(refusal("lattice.nx = 3\n[lattice]\nny = 4\n"),
             Contains("fuzz.toml:2: malformed TOML: "));
  CHECK(refusal("[lattice]\nnx.y = 3\n") ==
        "fuzz.toml:2: lattice.nx: expected an integer, got table");
}
