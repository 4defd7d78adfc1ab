#include "stickslip/output/checkpoint.hpp"

#include <cmath>
#include <fstream>
#include <set>

#include "stickslip/output/writers.hpp"

namespace stickslip {
namespace {

constexpr const char* kMagic = "stickslip-checkpoint 1";

}  // namespace

nlohmann::json restart_identity(const nlohmann::json& case_json) {
  nlohmann::json id = case_json;
  id.erase("source");
  if (id.contains("output")) {
    id["output"].erase("dir");
    id["output"].erase("format");    // changes no number (a restart needs the same files anyway)
    id["output"].erase("max_rows");  // a guard, not a parameter
  }
  if (id.contains("run")) id["run"].erase("checkpoint_every");  // may change between attempts
  if (id.contains("solver")) id["solver"].erase("threads");     // changes no number, bit for bit
  return id;
}

std::vector<CaseDifference> case_differences(const nlohmann::json& written, const Case& current) {
  const nlohmann::json then = restart_identity(written);
  const nlohmann::json now = restart_identity(to_json(current));
  const nlohmann::json defaults = restart_identity(to_json(Case{}));
  // A value as a message shows it: as JSON (strings quoted, as in a case
  // file), a long one (a list of contacts) cut short.
  auto shown = [](const nlohmann::json* value) {
    if (!value) return std::string("unset");
    std::string text = value->dump();
    if (text.size() > 60) text = text.substr(0, 57) + "...";
    return text;
  };
  auto find = [](const nlohmann::json& j, const std::string& key) -> const nlohmann::json* {
    const auto it = j.find(key);
    return it == j.end() ? nullptr : &*it;
  };
  std::vector<CaseDifference> differences;
  auto compare = [&](const std::string& key, const nlohmann::json* a, const nlohmann::json* b) {
    if (a && b ? *a != *b : a != b) differences.push_back({key, shown(a), shown(b)});
  };
  std::set<std::string> sections;
  for (const auto* j : {&then, &now})
    for (const auto& [section, keys] : j->items()) sections.insert(section);
  for (const auto& section : sections) {
    const nlohmann::json* a = find(then, section);
    const nlohmann::json* b = find(now, section);
    const nlohmann::json* d = find(defaults, section);
    if ((a && !a->is_object()) || (b && !b->is_object())) {
      compare(section, a, b);
      continue;
    }
    // A section the written case lacks was added later: every key its default.
    static const nlohmann::json kNone = nlohmann::json::object();
    const nlohmann::json& keys_then = a ? *a : kNone;
    const nlohmann::json& keys_now = b ? *b : kNone;
    std::set<std::string> keys;
    for (const auto* j : {&keys_then, &keys_now})
      for (const auto& [key, value] : j->items()) keys.insert(key);
    for (const auto& key : keys) {
      const nlohmann::json* x = find(keys_then, key);
      // A key written before it existed meant its default.
      if (!x && d && d->is_object()) x = find(*d, key);
      compare(section + "." + key, x, find(keys_now, key));
    }
  }
  return differences;
}

bool same_case(const nlohmann::json& written, const Case& current) {
  return case_differences(written, current).empty();
}

std::string describe(const std::vector<CaseDifference>& differences,
                     const std::string& written_as) {
  std::string text;
  for (const auto& d : differences)
    text += (text.empty() ? "" : "; ") + d.key + ": " + d.written + " in the " + written_as + ", " +
            d.current + " in the case";
  return text;
}

// Layout: a magic line, one line of JSON (everything but the state), then the
// state as raw doubles; the state's length is in the JSON.
void write_checkpoint(const std::filesystem::path& dir, const Checkpoint& c) {
  nlohmann::json header = {{"t", c.t},
                           {"output_index", c.output_index},
                           {"impulse_at_average", c.impulse_at_average},
                           {"state_size", c.state.size()},
                           {"stats", c.stats},
                           {"wall_seconds", c.wall_seconds},
                           {"case", c.case_json},
                           {"git_commit", c.git_commit},
                           {"segments", nlohmann::json::array()},
                           {"recorders", c.recorders}};
  auto& segments = header["segments"];
  for (const auto& seg : c.segments)
    segments.push_back({{"from", seg.from}, {"git_commit", seg.git_commit}});
  write_atomically(dir / kCheckpointFile, [&](std::ostream& out) {
    out << kMagic << '\n' << header.dump() << '\n';
    out.write(reinterpret_cast<const char*>(c.state.data()),
              static_cast<std::streamsize>(c.state.size() * sizeof(double)));
  });
}

Checkpoint read_checkpoint(const std::filesystem::path& dir) {
  const auto file = dir / kCheckpointFile;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw OutputError(file.string() + ": no checkpoint to restart from");
  std::string magic, line;
  std::getline(in, magic);
  if (magic != kMagic) throw OutputError(file.string() + ": not a stickslip checkpoint");
  std::getline(in, line);
  Checkpoint c;
  try {
    // impulse_at_average is NaN before t_avg; JSON writes NaN as null.
    const auto h = nlohmann::json::parse(line);
    c.t = h.at("t");
    c.output_index = h.at("output_index");
    c.impulse_at_average = h.at("impulse_at_average").is_null()
                               ? std::nan("")
                               : h.at("impulse_at_average").get<double>();
    c.state.resize(h.at("state_size").get<std::size_t>());
    c.stats = h.at("stats").get<SolverStats>();
    // Absent only in checkpoints of older code, which the restart refuses by version.
    c.wall_seconds = h.value("wall_seconds", 0.0);
    c.case_json = h.at("case");
    c.git_commit = h.at("git_commit");
    // Absent in checkpoints of older code: one attempt, by the writer, from 0.
    if (h.contains("segments")) {
      for (const auto& seg : h.at("segments"))
        c.segments.push_back({seg.at("from").get<double>(), seg.at("git_commit")});
    } else {
      c.segments.push_back({0.0, c.git_commit});
    }
    // Absent in checkpoints of older code: the recorders saved nothing.
    c.recorders = h.value("recorders", nlohmann::json::object());
  } catch (const nlohmann::json::exception& e) {
    throw OutputError(file.string() + ": damaged checkpoint header: " + e.what());
  }
  in.read(reinterpret_cast<char*>(c.state.data()),
          static_cast<std::streamsize>(c.state.size() * sizeof(double)));
  if (!in) throw OutputError(file.string() + ": truncated checkpoint");
  return c;
}

}  // namespace stickslip
