// A Case as the text of a case file (to_toml in case.hpp): every value
// resolved, in the sections and keys of the schema (to_json's), numbers in
// the fewest digits that read back exactly, output.dir absolute.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "stickslip/case/case.hpp"
#include "stickslip/case/toml_text.hpp"

namespace stickslip {

namespace {

using nlohmann::json;

std::string value_text(const json& v) {
  switch (v.type()) {
    case json::value_t::boolean:
      return v.get<bool>() ? "true" : "false";
    case json::value_t::number_integer:
      return std::to_string(v.get<long long>());
    case json::value_t::number_unsigned:
      return std::to_string(v.get<unsigned long long>());
    case json::value_t::number_float: {
      std::string text = toml_text::fmt(v.get<double>());
      // "1" would read back as an integer; the reader takes either, a reader of the file may not.
      if (text.find_first_of(".eEni") == std::string::npos) text += ".0";
      return text;
    }
    case json::value_t::string:
      return v.dump();  // a JSON string is a TOML basic string
    case json::value_t::array: {
      std::string text = "[";
      for (std::size_t i = 0; i < v.size(); ++i) text += (i ? ", " : "") + value_text(v[i]);
      return text + "]";
    }
    case json::value_t::object: {
      std::string text = "{";
      bool first = true;
      for (const auto& [key, item] : v.items()) {
        text += (first ? "" : ", ") + key + " = " + value_text(item);
        first = false;
      }
      return text + "}";
    }
    default:
      return "\"\"";  // null: to_json writes none
  }
}

// Values that mean "unset" in the Case and that a case file may not spell:
// left out, so that they read back as unset.
bool unset(const std::string& section, const std::string& key, const json& v) {
  return (section == "output" && key == "dir" && v.get<std::string>().empty()) ||
         (section == "solver" && key == "audit_bound" && v.get<double>() == 0.0) ||
         (section == "interface" && key == "contacts" && v.empty());
}

// Keys the case may not give beside others (the reader refuses coverage and
// seed beside an explicit contacts list): left out, so the text reads back.
bool excluded(const Case& c, const std::string& section, const std::string& key) {
  return section == "interface" && (key == "coverage" || key == "seed") &&
         !c.interface.contacts.empty();
}

}  // namespace

std::string to_toml(const Case& c) {
  const json resolved = to_json(c);
  std::string text = "# stickslip case, every value resolved (from " +
                     toml_text::printable(c.source.string()) + ")\n";
  for (const auto& [section, keys] : resolved.items()) {
    if (!keys.is_object()) continue;  // "source"
    text += "\n[" + section + "]\n";
    for (const auto& [key, v] : keys.items()) {
      if (unset(section, key, v) || excluded(c, section, key)) continue;
      if (section == "output" && key == "dir") {
        // Absolute: a relative dir would be read against the new file's directory.
        text += "dir = " + value_text(std::filesystem::absolute(c.output.dir).string()) + "\n";
        continue;
      }
      if (section == "interface" && key == "contacts") {
        text += "contacts = [\n";
        for (const auto& contact : v) text += "  " + value_text(contact) + ",\n";
        text += "]\n";
        continue;
      }
      text += key + " = " + value_text(v) + "\n";
    }
  }
  return text;
}

}  // namespace stickslip
