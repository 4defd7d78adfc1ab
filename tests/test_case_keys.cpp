// The case schema as one list: every key is read into its field and written by
// to_json, and the key reference (`stickslip keys`, docs/keys.md) is made
// from the same rows, with defaults read from a default-constructed Case.

#include <catch2/catch.hpp>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "sandbox.hpp"
#include "stickslip/case/keys.hpp"
#include "stickslip/case/reader.hpp"

using namespace stickslip;
using Catch::Contains;
using Catch::StartsWith;

namespace {

// "section.key" of every value that differs between a and b (either may lack one).
std::set<std::string> differing(const nlohmann::json& a, const nlohmann::json& b) {
  std::set<std::string> out;
  auto walk = [&](const nlohmann::json& x, const nlohmann::json& y) {
    for (const auto& [section, keys] : x.items()) {
      if (!keys.is_object()) continue;  // "source"
      for (const auto& [key, v] : keys.items())
        if (!y.contains(section) || !y[section].contains(key) || y[section][key] != v)
          out.insert(section + "." + key);
    }
  };
  walk(a, b);
  walk(b, a);
  return out;
}

struct Given {
  std::string value;               // a TOML value other than the default
  std::vector<std::string> needs;  // other keys that value needs (section.key=value)
};

// A value for every key. A key added to the schema without a line here fails
// the test below, so it cannot go unread or unwritten.
const std::map<std::string, Given>& given_values() {
  static const std::map<std::string, Given> values = {
      {"lattice.nx", {"4"}},
      {"lattice.ny", {"5"}},
      {"lattice.nz", {"3"}},
      {"lattice.spacing", {"2e-4"}},
      {"material.density", {"2e3"}},
      {"material.youngs_modulus", {"2e7"}},
      {"material.poisson_ratio", {"0.3"}},
      {"material.grad_div", {"\"navier\"", {"material.poisson_ratio=0.3"}}},
      {"damping.bulk", {"0.2"}},
      {"damping.contact", {"0.3"}},
      {"interface.coverage", {"0.2"}},
      {"interface.seed", {"2"}},
      {"interface.shear_stress", {"1e6"}},
      {"interface.shape", {"0.2"}},
      {"interface.v_m", {"2e-3"}},
      {"interface.spread", {"0.25"}},
      {"interface.epsilon", {"0.02"}},
      {"interface.max_pressure", {"2e6"}},
      {"interface.slip_threshold", {"2"}},
      {"interface.patch", {"2"}},
      // One law today: its only value is the default (checked below).
      {"interface.law", {"\"paper\""}},
      {"interface.contacts", {"[{site = [1, 2], v_star = 1e-3}]"}},
      {"drive.velocity", {"2e-3"}},
      {"run.t_end", {"6e-3"}},
      {"run.average_from", {"2e-3"}},
      {"run.initial", {"\"sliding\""}},
      {"run.checkpoint_every", {"1e-4"}},
      {"solver.method", {"\"dirk\""}},
      {"solver.linear_solver", {"\"fft\"", {"solver.method=\"dirk\""}}},
      {"solver.order", {"3"}},
      {"solver.step", {"1e-7"}},
      {"solver.rtol", {"1e-7"}},
      {"solver.atol_displacement", {"1e-12"}},
      {"solver.atol_velocity", {"1e-9"}},
      {"solver.threads", {"2"}},
      {"solver.max_steps", {"1000"}},
      {"solver.multirate_min_fast", {"8"}},
      {"solver.audit_bound", {"1e-3"}},
      {"output.dir", {"\"elsewhere\""}},
      {"output.interval", {"2e-6"}},
      {"output.max_rows", {"100000"}},
      {"output.traces", {"[0]"}},
      {"output.events", {"\"none\""}},
      {"output.steps", {"true"}},
      {"output.attempts", {"true"}},
      {"output.final_state", {"true"}},
      {"output.signals", {"true"}},
      {"output.format", {"\"hdf5\""}},
  };
  return values;
}

}  // namespace

TEST_CASE("every schema key is read into its field and written by to_json, alone", "[case]") {
  REQUIRE(case_keys().size() == given_values().size());
  for (const CaseKey& k : case_keys()) {
    const std::string name = k.section + "." + k.key;
    INFO(name);
    const auto it = given_values().find(name);
    REQUIRE(it != given_values().end());  // a new key needs its value in the table above
    const auto& [value, needs] = it->second;
    std::vector<std::string> sets = needs;
    const nlohmann::json base = to_json(parse_case("", "cases/t.toml", sets));
    sets.push_back(name + "=" + value);
    const nlohmann::json with = to_json(parse_case("", "cases/t.toml", sets));
    // A key with a single choice (interface.law) has no other value to give:
    // given, it must be read and written back as that choice.
    const bool only_value = value == k.default_value;
    // Listed contacts replace coverage and seed, which the resolved case then leaves out.
    const std::set<std::string> changes =
        only_value ? std::set<std::string>{}
        : name == "interface.contacts"
            ? std::set<std::string>{name, "interface.coverage", "interface.seed"}
            : std::set<std::string>{name};
    CHECK(differing(base, with) == changes);
    CHECK(with.at(k.section).contains(k.key));
  }
}

TEST_CASE("to_json writes no key the schema lacks", "[case]") {
  std::vector<std::string> sets;  // every key given: none left out as unset
  for (const auto& [name, given] : given_values())
    if (name != "interface.contacts" && name != "interface.patch" &&
        name != "solver.linear_solver" && name != "solver.method")
      sets.push_back(name + "=" + given.value);
  const nlohmann::json j = to_json(parse_case("", "cases/t.toml", sets));
  std::set<std::string> schema_keys, json_keys;
  for (const CaseKey& k : case_keys()) schema_keys.insert(k.section + "." + k.key);
  for (const auto& [section, keys] : j.items())
    if (keys.is_object())
      for (const auto& [key, v] : keys.items()) json_keys.insert(section + "." + key);
  CHECK(json_keys == schema_keys);
}

TEST_CASE("the key reference takes defaults from a default Case, and has every column", "[case]") {
  std::map<std::string, CaseKey> by_name;
  for (const CaseKey& k : case_keys()) {
    INFO(k.section + "." + k.key);
    CHECK_FALSE(k.default_value.empty());
    CHECK_FALSE(k.allowed.empty());
    CHECK_FALSE(k.help.empty());
    by_name[k.section + "." + k.key] = k;
  }
  CHECK(by_name.at("lattice.nx").default_value == "15");
  CHECK(by_name.at("interface.v_m").default_value == "0.001");
  CHECK(by_name.at("interface.v_m").unit == "m/s");
  CHECK(by_name.at("interface.shear_stress").default_value == "6.5e6");
  CHECK(by_name.at("interface.coverage").allowed == "in (0, 1]");
  CHECK(by_name.at("material.grad_div").default_value == "\"paper\"");
  CHECK(by_name.at("material.grad_div").allowed == "\"paper\", \"navier\"");
  CHECK(by_name.at("interface.law").default_value == "\"paper\"");
  CHECK(by_name.at("interface.law").allowed == "\"paper\"");
  CHECK(by_name.at("solver.method").default_value == "\"auto\"");
  CHECK_THAT(by_name.at("solver.method").allowed, Contains("\"multirate\""));
  CHECK(by_name.at("output.steps").default_value == "false");
  // Values that mean unset, which a case file cannot spell.
  for (const char* unset : {"solver.atol_displacement", "solver.atol_velocity",
                            "solver.audit_bound", "output.dir", "interface.contacts"})
    CHECK(by_name.at(unset).default_value == "unset");
}

TEST_CASE("stickslip keys prints every key, one key, or refuses an unknown one", "[cli]") {
  const test::Sandbox box;
  const test::Result all = box.run({"keys"});
  CHECK(all.code == 0);
  CHECK(all.out == keys_text());
  for (const CaseKey& k : case_keys())
    CHECK_THAT(all.out, Contains(k.section + "." + k.key + " = "));

  const test::Result one = box.run({"keys", "interface.v_m"});
  CHECK(one.code == 0);
  CHECK(one.out ==
        "interface.v_m = 0.001  (m/s; > 0)\n  v_m: centre of the log-uniform v* distribution\n");

  const test::Result section = box.run({"keys", "damping"});
  CHECK(section.code == 0);
  CHECK(section.out == keys_text("damping"));

  const test::Result unknown = box.run({"keys", "interface.v_n"});
  CHECK(unknown.code == 2);
  CHECK(unknown.out.empty());
  CHECK_THAT(unknown.err, StartsWith("error: unknown key 'v_n'"));
  CHECK_THAT(unknown.err, Contains("did you mean 'v_m'?"));
}

TEST_CASE("an unknown key in a case points to stickslip keys", "[cli]") {
  const test::Sandbox box;
  const auto file = box.write("bad.toml", "[interface]\ncoverag = 0.5\n");
  const test::Result r = box.run({"run", file.string(), "--quiet"});
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Contains("did you mean 'coverage'?); every key: stickslip keys\n"));
}

TEST_CASE("docs/keys.md is what stickslip keys --markdown prints", "[cli]") {
  const test::Sandbox box;
  const test::Result r = box.run({"keys", "--markdown"});
  CHECK(r.code == 0);
  CHECK(r.out == keys_markdown());
  INFO("regenerate it: build/stickslip keys --markdown > docs/keys.md");
  CHECK(test::slurp(std::filesystem::path(STICKSLIP_SOURCE_DIR) / "docs" / "keys.md") == r.out);
}
