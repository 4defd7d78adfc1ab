#include "stickslip/output/checkpoint.hpp"

#include <cmath>
#include <fstream>

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
    id["output"].erase("format");  // changes no number (a restart needs the same files anyway)
  }
  if (id.contains("run")) id["run"].erase("checkpoint_every");  // may change between attempts
  if (id.contains("solver")) id["solver"].erase("threads");     // changes no number, bit for bit
  return id;
}

bool same_case(const nlohmann::json& written, const Case& current) {
  nlohmann::json then = restart_identity(written);
  const nlohmann::json now = restart_identity(to_json(current));
  const nlohmann::json defaults = restart_identity(to_json(Case{}));
  for (const auto& [section, keys] : now.items()) {
    if (!keys.is_object()) continue;
    if (!then.contains(section)) then[section] = nlohmann::json::object();  // a section added later
    if (!then[section].is_object()) continue;
    for (const auto& [key, value] : keys.items())
      if (!then[section].contains(key) && defaults.contains(section) &&
          defaults[section].contains(key) && defaults[section][key] == value)
        then[section][key] = value;
  }
  return then == now;
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
