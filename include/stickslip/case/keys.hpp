#pragma once
// The reference of every case-file key, from the reader's schema
// (src/case/reader.cpp): `stickslip keys` prints it and docs/keys.md is it.

#include <string>
#include <vector>

namespace stickslip {

struct CaseKey {
  std::string section, key;
  // As a case file spells it, read from to_json(Case{}) (the member
  // initialisers of case.hpp); "unset" where the Case's value means unset (a
  // value the key's own rule refuses, or none in to_json).
  std::string default_value;
  std::string unit;     // SI; empty for a plain number, a word or a flag
  std::string allowed;  // range or choices, as the reader checks them
  std::string help;     // what it means
};

// Every key, in the schema's order.
const std::vector<CaseKey>& case_keys();

// "interface.v_m = 0.001  (m/s; > 0)\n  v_m: centre of ...\n".
std::string key_reference(const CaseKey& key);
// Every key's reference, or the keys of one section ("interface").
std::string keys_text(const std::string& section = "");
// docs/keys.md: a table per section.
std::string keys_markdown();

}  // namespace stickslip
