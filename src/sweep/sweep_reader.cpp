// Sweep-file reader (the format is in stickslip/sweep/sweep.hpp). Every value
// is checked against the base case before anything runs, and every error
// names the sweep file, the line and the key, like the case reader's.

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "stickslip/case/reader.hpp"
#include "stickslip/case/toml_text.hpp"
#include "stickslip/sweep/sweep.hpp"

namespace stickslip {
namespace {

using namespace toml_text;
namespace fs = std::filesystem;

struct SweepReader {
  std::string source;
  [[noreturn]] void fail(const toml::node& n, const std::string& key,
                         const std::string& what) const {
    throw CaseError(source + ":" + std::to_string(n.source().begin.line) + ": " + key + ": " +
                    what);
  }
  [[noreturn]] void fail(const std::string& what) const { throw CaseError(source + ": " + what); }
};

// A value as --set takes it (TOML), and as a label for directories and CSV.
std::pair<std::string, std::string> value_text(const toml::node& v) {
  if (auto f = v.value_exact<double>()) return {fmt(*f), fmt(*f)};
  if (auto i = v.value_exact<std::int64_t>()) return {std::to_string(*i), std::to_string(*i)};
  if (auto s = v.value_exact<std::string>()) {
    std::ostringstream quoted;
    quoted << toml::value<std::string>(*s);
    return {quoted.str(), *s};
  }
  std::ostringstream text;
  if (auto* a = v.as_array())
    text << *a;
  else if (auto* t = v.as_table())
    text << *t;
  else if (auto b = v.value_exact<bool>())
    text << (*b ? "true" : "false");
  std::string label = text.str();
  label.erase(
      std::remove_if(label.begin(), label.end(), [](char c) { return c == ' ' || c == '\n'; }),
      label.end());
  return {text.str(), label};
}

// Flattens [vary] or [set]: nested tables (from dotted keys) become "a.b".
void leaves(const toml::table& t, const std::string& prefix,
            std::vector<std::pair<std::string, const toml::node*>>& out) {
  for (auto&& [k, v] : t) {
    const std::string key =
        prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    if (auto* sub = v.as_table(); sub && !prefix.empty()) {
      out.emplace_back(key, &v);  // a table value of a case key (not used by any key today)
    } else if (sub) {
      leaves(*sub, key, out);
    } else {
      out.emplace_back(key, &v);
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.second->source().begin.line < b.second->source().begin.line;
  });
}

std::string sanitized(std::string s) {
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '=' || c == '+' ||
          c == '-' || c == '_'))
      c = '-';
  return s;
}

}  // namespace

Sweep read_sweep(const fs::path& file, const std::vector<std::string>& extra_sets) {
  SweepReader r{printable(file.string())};
  std::error_code ec;
  if (fs::is_directory(file, ec)) r.fail("cannot read sweep file: it is a directory");
  std::ifstream in(file, std::ios::binary);
  if (!in) r.fail(std::string("cannot read sweep file: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  toml::table root;
  try {
    root = parse_toml(text.str(), std::string_view(file.native()));
  } catch (const TomlSyntaxError& e) {
    throw CaseError(r.source + ":" + std::to_string(e.line) + ": malformed TOML: " + e.description);
  }

  Sweep sweep;
  sweep.source = file;
  for (auto&& [k, v] : root) {
    const std::string name(k.str());
    if (name != "sweep" && name != "vary" && name != "set")
      r.fail(v, printable(name), "unknown section" + suggest(name, {"sweep", "vary", "set"}));
    if (!v.is_table()) r.fail(v, name, "expected a table [" + name + "], got " + type_name(v));
  }
  const toml::table* head = root["sweep"].as_table();
  if (!head) r.fail("missing [sweep] with case = \"<base case file>\"");
  bool have_case = false;
  for (auto&& [k, v] : *head) {
    const std::string key = "sweep." + printable(k.str());
    if (k.str() == "case") {
      auto s = v.value_exact<std::string>();
      if (!s || s->empty()) r.fail(v, key, "expected the base case file (a string)");
      sweep.base_case = fs::path(*s).is_absolute() ? fs::path(*s) : file.parent_path() / *s;
      have_case = true;
    } else if (k.str() == "average_over") {
      auto s = v.value_exact<std::string>();
      if (!s) r.fail(v, key, "expected a case key such as \"interface.seed\"");
      if (auto problem = case_key_problem(*s); !problem.empty()) r.fail(v, key, problem);
      sweep.average_over = *s;
    } else {
      r.fail(v, key, "unknown key" + suggest(k.str(), {"case", "average_over"}));
    }
  }
  if (!have_case) r.fail(*head, "sweep", "missing case = \"<base case file>\"");

  std::vector<std::pair<std::string, const toml::node*>> fixed, varied;
  if (auto* t = root["set"].as_table()) leaves(*t, "", fixed);
  // [vary]: each key its own group; each [[vary.together]] table one group.
  std::map<std::string, std::size_t> group_of;
  std::size_t groups = 0;
  if (auto* t = root["vary"].as_table()) {
    leaves(*t, "", varied);
    std::erase_if(varied, [](const auto& kv) { return kv.first == "together"; });
    for (const auto& [key, v] : varied) group_of[key] = groups++;
    if (const toml::node* together = t->get("together")) {
      const auto* tables = together->as_array();
      if (!tables || !tables->is_array_of_tables())
        r.fail(*together, "vary.together",
               "expected [[vary.together]] tables of keys that change in step");
      for (const auto& table : *tables) {
        std::vector<std::pair<std::string, const toml::node*>> linked;
        leaves(*table.as_table(), "", linked);
        if (linked.size() < 2)
          r.fail(table, "vary.together", "needs at least two keys that change in step");
        const auto* first = linked.front().second->as_array();
        for (const auto& [key, v] : linked) {
          const auto* list = v->as_array();
          if (!list || !first || list->size() != first->size())
            r.fail(*v, "vary.together." + printable(key),
                   "expected a list as long as vary.together." + printable(linked.front().first) +
                       "'s (" + std::to_string(first ? first->size() : 0) +
                       " values): the keys change in step");
          group_of[key] = groups;
          varied.emplace_back(key, v);
        }
        ++groups;
      }
    }
    std::stable_sort(varied.begin(), varied.end(), [](const auto& a, const auto& b) {
      return a.second->source().begin.line < b.second->source().begin.line;
    });
  }
  if (varied.empty()) r.fail(*head, "vary", "a sweep needs [vary] with at least one key");

  std::set<std::string> seen;
  auto check_key = [&](const std::string& section, const std::string& key, const toml::node& v) {
    const std::string where = section + "." + printable(key);
    if (auto problem = case_key_problem(key); !problem.empty()) r.fail(v, where, problem);
    if (key == "output.dir")
      r.fail(v, where, "each point writes to its own directory in the sweep's output; use --out");
    if (!seen.insert(key).second) r.fail(v, where, "is given twice (in [set] and [vary]?)");
  };
  for (const auto& [key, v] : fixed) {
    check_key("set", key, *v);
    sweep.fixed.push_back(key + "=" + value_text(*v).first);
  }
  for (const auto& s : extra_sets) sweep.fixed.push_back(s);

  // The base case with [set] and --set, and below each value alone with them,
  // name the line at fault better than a whole point does. But a check
  // between keys may fail there and pass on every point ([set]
  // run.average_from = 2e-3 with [vary] run.t_end = [5e-3]): such an error
  // is kept, and thrown only if a whole point is refused for the same reason
  // (else the point's own error is).
  struct Refusal {
    CaseError error;
    std::string reason;  // the case reader's message
  };
  std::optional<Refusal> first_refusal;
  try {
    (void)read_case(sweep.base_case, sweep.fixed);
  } catch (const CaseError& e) {
    first_refusal =
        Refusal{CaseError(std::string(e.what()) + " (base case of " + r.source + ")"), e.what()};
  }

  for (const auto& [key, v] : varied) {
    check_key("vary", key, *v);
    const std::string where = "vary." + printable(key);
    // A list of values, or a table of labelled values (for values whose own
    // text makes a poor directory name: { dx1 = [...], dx7 = [...] }).
    std::vector<std::pair<std::string, const toml::node*>> items;
    if (const auto* list = v->as_array()) {
      for (const auto& item : *list) items.emplace_back(value_text(item).second, &item);
    } else if (const auto* labelled = v->as_table()) {
      for (auto&& [label, item] : *labelled) items.emplace_back(std::string(label.str()), &item);
      std::stable_sort(items.begin(), items.end(), [](const auto& a, const auto& b) {
        return a.second->source().begin.line < b.second->source().begin.line;
      });
    }
    if (items.empty())
      r.fail(*v, where, "expected a non-empty list of values (or a table of labelled values)");
    SweepAxis axis{key, {}, {}, static_cast<int>(v->source().begin.line), group_of.at(key)};
    const bool linked = std::count_if(group_of.begin(), group_of.end(),
                                      [&](const auto& g) { return g.second == axis.group; }) > 1;
    for (const auto& [item_label, node] : items) {
      const toml::node& item = *node;
      auto toml_value = value_text(item).first;
      const std::string& label = item_label;
      // A key that changes in step with others may repeat a value.
      if (!linked && std::find(axis.labels.begin(), axis.labels.end(), label) != axis.labels.end())
        r.fail(item, where, "repeats the value " + label);
      // Alone against the base case; linked values only together, as points.
      auto overrides = sweep.fixed;
      overrides.push_back(key + "=" + toml_value);
      try {
        if (!linked && !first_refusal) (void)read_case(sweep.base_case, overrides);
      } catch (const CaseError& e) {
        try {
          r.fail(item, where, "value " + label + " is refused by the case: " + e.what());
        } catch (const CaseError& blamed) {
          first_refusal = Refusal{blamed, e.what()};
        }
      }
      axis.values.push_back(std::move(toml_value));
      axis.labels.push_back(label);
    }
    sweep.axes.push_back(std::move(axis));
  }
  // A --set of a key the sweep varies would be overridden by every point: lost.
  for (const auto& set : extra_sets) {
    std::string key = set.substr(0, set.find('='));
    key.erase(0, key.find_first_not_of(" \t"));
    key.erase(key.find_last_not_of(" \t") + 1);
    if (std::any_of(sweep.axes.begin(), sweep.axes.end(),
                    [&](const SweepAxis& a) { return a.key == key; }))
      throw CaseError("--set " + printable(key) + ": " + r.source +
                      " varies it; change its values in [vary] instead");
  }

  // Checks between keys (average_from < t_end, ...) need whole points.
  try {
    (void)sweep_points(sweep);
  } catch (const CaseError& e) {
    if (first_refusal && std::string_view(e.what()).ends_with(first_refusal->reason))
      throw first_refusal->error;
    throw;
  }
  return sweep;
}

std::vector<SweepPoint> sweep_points(const Sweep& sweep) {
  // Short names in directories ("coverage=0.1") unless two axes share one.
  std::vector<std::string> names;
  for (const auto& a : sweep.axes) names.push_back(a.key.substr(a.key.rfind('.') + 1));
  for (std::size_t i = 0; i < names.size(); ++i)
    if (std::count(names.begin(), names.end(), names[i]) > 1) names[i] = sweep.axes[i].key;

  // Every combination of the groups, the group of the first axis slowest.
  std::vector<std::size_t> group_order, group_size;
  for (const auto& a : sweep.axes)
    if (std::find(group_order.begin(), group_order.end(), a.group) == group_order.end()) {
      group_order.push_back(a.group);
      group_size.push_back(a.values.size());
    }
  std::size_t total = 1;
  for (std::size_t n : group_size) total *= n;
  std::vector<SweepPoint> points;
  points.reserve(total);
  for (std::size_t index = 0; index < total; ++index) {
    SweepPoint p;
    p.index = index;
    p.overrides = sweep.fixed;
    std::map<std::size_t, std::size_t> value_of;  // group -> its value's index
    std::size_t rest = index, stride = total;
    for (std::size_t g = 0; g < group_order.size(); ++g) {
      stride /= group_size[g];
      value_of[group_order[g]] = rest / stride;
      rest %= stride;
    }
    for (std::size_t i = 0; i < sweep.axes.size(); ++i) {
      const auto& a = sweep.axes[i];
      const std::size_t k = value_of.at(a.group);
      p.labels.push_back(a.labels[k]);
      p.overrides.push_back(a.key + "=" + a.values[k]);
      if (i > 0) p.name += '_';
      p.name += sanitized(names[i] + '=' + a.labels[k]);
    }
    try {
      p.c = read_case(sweep.base_case, p.overrides);
    } catch (const CaseError& e) {
      throw CaseError(printable(sweep.source.string()) + ": point " + p.name +
                      " is refused by the case: " + e.what());
    }
    points.push_back(std::move(p));
  }
  return points;
}

}  // namespace stickslip
