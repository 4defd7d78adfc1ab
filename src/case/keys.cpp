// The key reference (case/keys.hpp) as text and as Markdown.

#include "stickslip/case/keys.hpp"

namespace stickslip {

std::string key_reference(const CaseKey& k) {
  std::string text = k.section + "." + k.key + " = " + k.default_value + "  (";
  if (!k.unit.empty()) text += k.unit + "; ";
  return text + k.allowed + ")\n  " + k.help + "\n";
}

std::string keys_text(const std::string& section) {
  std::string text;
  for (const CaseKey& k : case_keys())
    if (section.empty() || k.section == section) text += key_reference(k);
  return text;
}

namespace {

std::string cell(const std::string& s) {  // a Markdown table cell: '|' escaped
  std::string out;
  for (char ch : s) out += ch == '|' ? std::string("\\|") : std::string(1, ch);
  return out;
}

}  // namespace

std::string keys_markdown() {
  std::string text =
      "# Case-file keys\n\n"
      "Every key of a case file, with its default, unit, allowed values and meaning. A case\n"
      "file lists only what differs from the defaults (the paper's parameters, MODEL.md §10).\n"
      "Generated from the schema in `src/case/reader.cpp` by `stickslip keys --markdown`\n"
      "(`stickslip keys section.key` prints one key); a test checks that this file is\n"
      "that output.\n";
  std::string section;
  for (const CaseKey& k : case_keys()) {
    if (k.section != section) {
      section = k.section;
      text += "\n## [" + section + "]\n\n| key | default | unit | allowed | meaning |\n" +
              "|---|---|---|---|---|\n";
    }
    const std::string value =
        k.default_value == "unset" ? k.default_value : "`" + k.default_value + "`";
    text += "| `" + k.key + "` | " + cell(value) + " | " + cell(k.unit) + " | " + cell(k.allowed) +
            " | " + cell(k.help) + " |\n";
  }
  return text;
}

}  // namespace stickslip
