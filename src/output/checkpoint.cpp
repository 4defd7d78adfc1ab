#include "stickslip/output/checkpoint.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <set>
#include <string_view>

#include "stickslip/output/writers.hpp"

namespace stickslip {
namespace {

// Format 2 carries a checksum of everything after its line, so a checkpoint
// damaged on a disk or in a copy is refused on restart instead of being
// integrated from a state no run reached. Format 1, from before the
// checksum, is still read, unchecked: it is another code version's, which a
// restart continues only with --any-version, and refusing it would strand
// the runs it holds.
constexpr const char* kMagic = "stickslip-checkpoint 2";
constexpr const char* kMagicUnchecked = "stickslip-checkpoint 1";
constexpr const char* kChecksumName = "fnv1a-64";

// 64-bit FNV-1a: a few lines, no dependency, and any change of a few bytes
// (a flipped bit, a block of zeros) changes it but with a chance of 2^-64.
std::uint64_t fnv1a_64(std::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (const unsigned char byte : bytes) {
    hash ^= byte;
    hash *= 0x100000001b3ull;
  }
  return hash;
}

std::string checksum_line(std::string_view body) {
  char line[48];
  std::snprintf(line, sizeof line, "%s %016llx", kChecksumName,
                static_cast<unsigned long long>(fnv1a_64(body)));
  return line;
}

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
  // Written before unset values were left out: audit_bound 0 is unset, and a
  // case listing its contacts uses no coverage or seed.
  if (id.contains("solver") && id["solver"].value("audit_bound", 1.0) == 0.0)
    id["solver"].erase("audit_bound");
  if (id.contains("interface") && id["interface"].contains("contacts")) {
    id["interface"].erase("coverage");
    id["interface"].erase("seed");
  }
  if (id.contains("solver")) id["solver"].erase("threads");  // changes no number, bit for bit
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

// Layout: a magic line, the checksum line, then what it sums: one line of
// JSON (everything but the state), then the state as raw doubles, whose
// length is in the JSON.
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
                           {"recorders", c.recorders},
                           {"tables", c.tables}};
  auto& segments = header["segments"];
  for (const auto& seg : c.segments)
    segments.push_back({{"from", seg.from}, {"git_commit", seg.git_commit}});
  std::string body = header.dump() + '\n';
  body.append(reinterpret_cast<const char*>(c.state.data()), c.state.size() * sizeof(double));
  write_atomically(dir / kCheckpointFile, [&](std::ostream& out) {
    out << kMagic << '\n' << checksum_line(body) << '\n' << body;
  });
}

Checkpoint read_checkpoint(const std::filesystem::path& dir) {
  const auto file = dir / kCheckpointFile;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw OutputError(file.string() + ": no checkpoint to restart from");
  std::string magic;
  std::getline(in, magic);
  if (magic != kMagic && magic != kMagicUnchecked)
    throw OutputError(file.string() + ": not a stickslip checkpoint");
  std::string checksum;
  if (magic == kMagic) std::getline(in, checksum);
  const std::string body(std::istreambuf_iterator<char>(in), {});
  // Checked before anything in it is believed (the state's length included).
  if (magic == kMagic && checksum != checksum_line(body))
    throw OutputError(file.string() +
                      ": checksum mismatch: the checkpoint is corrupted (its content is no "
                      "longer what the run wrote); it is left as it is: restore it from a copy, "
                      "or start the run afresh with --overwrite");
  const auto end_of_header = body.find('\n');
  const std::string line = body.substr(0, end_of_header);
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
    // Absent in checkpoints of older code: how far the tables reached is
    // unknown, and not checked.
    c.tables = h.value("tables", std::map<std::string, double>{});
  } catch (const nlohmann::json::exception& e) {
    throw OutputError(file.string() + ": damaged checkpoint header: " + e.what());
  }
  const std::size_t state_bytes = c.state.size() * sizeof(double);
  if (end_of_header == std::string::npos || body.size() - end_of_header - 1 < state_bytes)
    throw OutputError(file.string() + ": truncated checkpoint");
  std::copy_n(body.data() + end_of_header + 1, state_bytes,
              reinterpret_cast<char*>(c.state.data()));
  return c;
}

}  // namespace stickslip
