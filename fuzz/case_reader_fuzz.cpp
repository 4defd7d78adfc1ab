// libFuzzer target for the case-file reader (scripts/fuzz builds and runs it).
// Any input must either parse or be refused with a CaseError; anything else
// escaping (another exception, a crash, an ASan/UBSan report) is a finding.
// The input is read as a case file, and its first line also as a --set value.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "stickslip/case/reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    (void)stickslip::parse_case(text, "fuzz.toml");
  } catch (const stickslip::CaseError&) {
  }
  try {
    (void)stickslip::parse_case("", "fuzz.toml", {std::string(text.substr(0, text.find('\n')))});
  } catch (const stickslip::CaseError&) {
  }
  return 0;
}
